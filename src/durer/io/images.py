"""Image output: colour, depth and normal visualisations, written atomically by file extension.

8-bit formats (PNG, TGA, PPM, BMP, JPEG, TIFF) go through Pillow; `.npy`, `.pfm`, `.hdr` (Radiance RGBE) and `.exr`
(OpenEXR, through the optional `openexr` package: `pip install durer[exr]`) keep the float values.
Course outputs are quantised as the course's Image class does: clamp to [0, 1], multiply by 255, truncate
(no transfer curve). Native outputs are sRGB-encoded and rounded, as image viewers expect.
"""

from __future__ import annotations

import os
import tempfile

import numpy as np
from PIL import Image, TgaImagePlugin, TiffImagePlugin  # noqa: F401

from ..errors import UsageError

# TgaImagePlugin and TiffImagePlugin are imported to register TGA and TIFF: Pillow would otherwise import every
# plugin (~45 ms) on the first save; PNG, PPM, BMP and JPEG are registered by Image.preinit.
EIGHT_BIT = {".png": "PNG", ".tga": "TGA", ".ppm": "PPM", ".bmp": "BMP", ".jpg": "JPEG", ".jpeg": "JPEG",
             ".tif": "TIFF", ".tiff": "TIFF"}
# Pillow's default JPEG (quality 75, chroma at half resolution) blurs a render's edges and coloured detail
SAVE_ARGS = {"JPEG": {"quality": 95, "subsampling": 0}}
RAW = (".npy", ".pfm", ".hdr", ".exr")
EXTENSIONS = tuple(EIGHT_BIT) + RAW


def check_extension(path: str) -> str:
    """The lower-case extension of an output path, or a UsageError naming the supported ones."""
    ext = os.path.splitext(path)[1].lower()
    if ext not in EXTENSIONS:
        raise UsageError(f"cannot write '{path}': unknown image extension '{ext}' (use one of "
                         f"{', '.join(EXTENSIONS)})")
    return ext


def quantize_course(values: np.ndarray) -> np.ndarray:
    """float in [0,1] -> uint8 the course's way: int(c * 255), clamped."""
    return np.clip(np.floor(np.nan_to_num(values) * 255.0), 0, 255).astype(np.uint8)


def encode_srgb(linear: np.ndarray) -> np.ndarray:
    """Linear radiance -> sRGB-encoded uint8 (IEC 61966-2-1 curve), rounded."""
    c = np.clip(np.nan_to_num(linear), 0.0, 1.0)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)
    return np.clip(np.round(s * 255.0), 0, 255).astype(np.uint8)


def depth_visualization(t: np.ndarray, near: float, far: float) -> np.ndarray:
    """Grey (far - t) / (far - near) clamped to [0,1]: near is white, far and misses black (course style)."""
    grey = np.clip((far - t) / (far - near), 0.0, 1.0)
    grey[~np.isfinite(t)] = 0.0
    return grey


def normal_visualization(normals: np.ndarray) -> np.ndarray:
    """|n| per channel, so a +-z normal is pure blue; misses (zero normals) stay black."""
    return np.abs(normals)


def _write_pfm(f, data: np.ndarray) -> None:
    data = np.asarray(data, dtype="<f4")
    colour = data.ndim == 3
    h, w = data.shape[:2]
    f.write(f"{'PF' if colour else 'Pf'}\n{w} {h}\n-1.0\n".encode("ascii"))
    f.write(np.ascontiguousarray(data[::-1]).tobytes())  # PFM rows run bottom to top


def rgbe(data: np.ndarray) -> np.ndarray:
    """Float RGB (H, W, 3), or grey (H, W), as Radiance RGBE bytes (H, W, 4): a shared exponent e = frexp of the
    largest channel, mantissas channel * 256 / 2^e (Ward, Graphics Gems II). Negative and NaN values are 0;
    values above 1e38 (infinities too) are 1e38, near the format's largest (exponent byte 255)."""
    rgb = np.asarray(data, dtype=np.float64)
    if rgb.ndim == 2:
        rgb = np.repeat(rgb[:, :, None], 3, axis=2)
    rgb = np.clip(np.nan_to_num(rgb, nan=0.0, posinf=1e38, neginf=0.0), 0.0, 1e38)
    top = rgb.max(axis=2)
    mantissa, exponent = np.frexp(top)
    out = np.zeros(rgb.shape[:2] + (4,), dtype=np.uint8)
    lit = top >= 1e-32
    scale = np.where(lit, mantissa * 256.0 / np.where(lit, top, 1.0), 0.0)
    out[..., :3] = np.clip(np.floor(rgb * scale[..., None]), 0, 255).astype(np.uint8)
    out[..., 3] = np.where(lit, np.clip(exponent + 128, 0, 255), 0).astype(np.uint8)
    return out


def _write_hdr(f, data: np.ndarray) -> None:
    """A Radiance .hdr file: its header, then the RGBE pixels flat, top row first (uncompressed scanlines,
    which every reader takes)."""
    pixels = rgbe(data)
    h, w = pixels.shape[:2]
    f.write(f"#?RADIANCE\n# written by durer\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode("ascii"))
    f.write(np.ascontiguousarray(pixels).tobytes())


def _openexr():
    try:
        import OpenEXR
    except ImportError:
        raise UsageError("writing .exr needs the openexr package (pip install openexr, or durer[exr])") from None
    return OpenEXR


def _write_exr(path: str, data: np.ndarray) -> None:
    """Float32 OpenEXR, ZIP-compressed: RGB for colour, Y for one channel; written beside and renamed."""
    pixels = np.ascontiguousarray(data, dtype=np.float32)
    write_exr_channels(path, {"RGB" if pixels.ndim == 3 else "Y": pixels})


def write_exr_channels(path: str, channels: dict[str, np.ndarray]) -> None:
    """An OpenEXR file of these float32 channels (name -> (H, W) or, for "RGB", (H, W, 3)), ZIP-compressed,
    written beside the target and renamed into place, so an error never leaves a partial file."""
    exr = _openexr()
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".durer-", suffix=".exr", dir=directory)
    os.close(fd)
    try:
        with exr.File({"compression": exr.ZIP_COMPRESSION, "type": exr.scanlineimage}, channels) as f:
            f.write(tmp)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def check_writable(path: str) -> None:
    """Raise unless an image can be written at `path`, naming it: UsageError for an unknown extension, and
    FileNotFoundError (missing folder), IsADirectoryError (a folder in the way) or PermissionError (a folder or
    file we may not write) with a one-line message, and UsageError if the format needs a package that is not
    installed (.exr: openexr). Called before rendering, so nothing is rendered in vain."""
    if check_extension(path) == ".exr":
        _openexr()
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise FileNotFoundError(f"cannot write '{path}': folder '{folder}' does not exist")
    if os.path.isdir(path):
        raise IsADirectoryError(f"cannot write '{path}': it is a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise PermissionError(f"cannot write '{path}': no permission to write in folder '{folder}'")
    if os.path.exists(path) and not os.access(path, os.W_OK):
        raise PermissionError(f"cannot write '{path}': the file exists and is read-only")


def write_atomic(path: str, write) -> None:
    """Call write(file) on a temporary file beside `path`, then rename it into place: never a half-written file.
    Any failure is an OSError naming `path` (never the temporary file)."""
    directory = os.path.dirname(os.path.abspath(path))
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=".durer-", suffix=os.path.splitext(path)[1], dir=directory)
        with os.fdopen(fd, "wb") as f:
            write(f)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600 files; give the usual permissions
        os.replace(tmp, path)
    except OSError as e:
        _remove(tmp)
        reason = "it is a folder" if os.path.isdir(path) else (e.strerror or str(e))
        error = OSError(f"cannot write '{path}': {reason}")
        error.errno = e.errno
        raise error from None
    except BaseException:
        _remove(tmp)
        raise


def _remove(tmp: str | None) -> None:
    if tmp is not None and os.path.exists(tmp):
        os.unlink(tmp)


def save_image(path: str, data: np.ndarray, *, course: bool = False) -> None:
    """Write (H,W,3) or (H,W) float data. 8-bit formats quantise (course: truncate, else sRGB); raw formats
    store the floats as they are."""
    ext = check_extension(path)
    data = np.asarray(data)
    if ext == ".npy":
        write_atomic(path, lambda f: np.save(f, data.astype(np.float32)))
        return
    if ext == ".pfm":
        write_atomic(path, lambda f: _write_pfm(f, data))
        return
    if ext == ".hdr":
        write_atomic(path, lambda f: _write_hdr(f, data))
        return
    if ext == ".exr":
        _write_exr(path, data)
        return
    pixels = quantize_course(data) if course else encode_srgb(data)
    if pixels.ndim == 2:
        pixels = np.repeat(pixels[:, :, None], 3, axis=2)
    image = Image.fromarray(np.ascontiguousarray(pixels), mode="RGB")
    fmt = EIGHT_BIT[ext]
    write_atomic(path, lambda f: image.save(f, format=fmt, **SAVE_ARGS.get(fmt, {})))


def read_texture(path: str, raw: bool = False) -> np.ndarray:
    """A texture image (H, W, 1 or 3) float32 of linear values: 8- and 16-bit images (PNG, JPEG, ... through
    Pillow) sRGB-decoded unless `raw`, grey ones (with or without alpha) one channel, alpha dropped; float images
    (.exr, .hdr, .pfm, .npy) as stored. ValueError naming the problem."""
    ext = os.path.splitext(path)[1].lower()
    if ext in (".exr", ".hdr", ".pfm", ".npy"):
        img = read_hdr(path)
        return (img[..., :1] if img.ndim == 3 and img.shape[2] in (1, 2) else
                img[..., :3] if img.ndim == 3 else img[..., None]).astype(np.float32)
    try:
        with Image.open(path) as im:
            im.load()
            grey = im.mode in ("L", "LA", "I;16", "I", "1", "F")
            if im.mode in ("I;16", "I;16B", "I;16L", "I"):
                data = np.asarray(im, dtype=np.float64) / 65535.0
            elif im.mode == "F":
                data = np.asarray(im, dtype=np.float64)
            else:
                data = np.asarray(im.convert("L" if grey else "RGB"), dtype=np.float64) / 255.0
    except (OSError, ValueError) as e:
        raise ValueError(f"cannot read image '{path}': {e}") from None
    if data.ndim == 2:
        data = data[:, :, None]
    if not raw:
        data = np.where(data <= 0.04045, data / 12.92, ((data + 0.055) / 1.055) ** 2.4)
    return data.astype(np.float32)


def _read_rgbe(f) -> np.ndarray:
    """Radiance RGBE pixels (H, W, 3) float64 from an open .hdr file: its header, then flat or run-length encoded
    scanlines (Ward's format; -Y H +X W orientation)."""
    if not f.readline().startswith(b"#?"):
        raise ValueError("not a Radiance file")
    while True:
        line = f.readline()
        if not line:
            raise ValueError("no resolution line")
        if line.strip() == b"":
            break
        if line.startswith(b"FORMAT=") and b"32-bit_rle_rgbe" not in line:
            raise ValueError(f"unsupported {line.strip().decode(errors='replace')}")
    size = f.readline().split()
    if len(size) != 4 or size[0] != b"-Y" or size[2] != b"+X":
        raise ValueError("durer reads .hdr files of -Y H +X W orientation")
    h, w = int(size[1]), int(size[3])
    buf = np.frombuffer(f.read(), dtype=np.uint8)
    out, pos = np.zeros((h, w, 4), np.uint8), 0
    for y in range(h):
        if 8 <= w < 32768 and pos + 4 <= len(buf) and buf[pos] == 2 and buf[pos + 1] == 2 and buf[pos + 2] < 128:
            pos += 4  # new-style RLE: each of the 4 components run-length coded in turn
            for c in range(4):
                x = 0
                while x < w:
                    n = int(buf[pos])
                    if n > 128:
                        out[y, x:x + n - 128, c] = buf[pos + 1]
                        x, pos = x + n - 128, pos + 2
                    else:
                        out[y, x:x + n, c] = buf[pos + 1:pos + 1 + n]
                        x, pos = x + n, pos + 1 + n
                    if n == 0 or x > w:
                        raise ValueError("bad run-length data")
        else:
            out[y] = buf[pos:pos + 4 * w].reshape(w, 4)
            pos += 4 * w
    e = out[..., 3].astype(np.int32)
    scale = np.where(e > 0, np.ldexp(1.0, e - 136), 0.0)
    return out[..., :3] * scale[..., None]


def read_hdr(path: str) -> np.ndarray:
    """A float image (H, W, C) from .exr (openexr), .hdr (Radiance RGBE), .pfm or .npy: environment maps. Raises
    ValueError naming the problem (unknown extension, unreadable file, no RGB channels)."""
    ext = os.path.splitext(path)[1].lower()
    try:
        if ext == ".hdr":
            with open(path, "rb") as f:
                return _read_rgbe(f)
        if ext == ".npy":
            return np.asarray(np.load(path), dtype=np.float64)
        if ext == ".pfm":
            with open(path, "rb") as f:
                kind = f.readline().strip()
                w, h = (int(x) for x in f.readline().split())
                scale = float(f.readline())
                c = 3 if kind == b"PF" else 1
                data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4", count=w * h * c)
            return data.reshape(h, w, c)[::-1].astype(np.float64)
        if ext == ".exr":
            exr = _openexr()
            with exr.File(path) as f:
                ch = f.channels()
                if "RGB" in ch or "RGBA" in ch:
                    return np.asarray(ch.get("RGB", ch.get("RGBA")).pixels, dtype=np.float64)
                if all(k in ch for k in "RGB"):
                    return np.stack([np.asarray(ch[k].pixels, dtype=np.float64) for k in "RGB"], axis=-1)
                raise ValueError(f"no RGB channels (found {', '.join(ch)})")
    except (OSError, ValueError, IndexError) as e:
        raise ValueError(f"cannot read image '{path}': {e}") from None
    raise ValueError(f"cannot read image '{path}': use .exr, .hdr, .pfm or .npy for an environment map")
