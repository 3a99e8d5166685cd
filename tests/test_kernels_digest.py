"""The arrays' 64-bit digest (kernels/digest.py): the same as a plain-Python transcription of its definition on
any bytes (every length: the four lanes, the single words, the tail), and any byte changed, the length or the
order changes it."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from durer.kernels.digest import digest

M = (1 << 64) - 1
P1, P2, P3, P4, P5 = (0x9E3779B185EBCA87, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9, 0x85EBCA77C2B2AE63,
                      0x27D4EB2F165667C5)


def _rotl(x: int, r: int) -> int:
    return ((x << r) | (x >> (64 - r))) & M


def _round(acc: int, word: int) -> int:
    return (_rotl((acc + word * P2) & M, 31) * P1) & M


def _reference(data: bytes) -> bytes:
    """The digest's definition in Python integers."""
    n = len(data) // 8
    words = [int.from_bytes(data[8 * k:8 * k + 8], "little") for k in range(n)]
    h, k = (P5 + len(data)) & M, 0
    if n >= 4:
        v = [(P1 + P2) & M, P2, 0, (-P1) & M]
        while k + 4 <= n:
            v = [_round(v[i], words[k + i]) for i in range(4)]
            k += 4
        h = (_rotl(v[0], 1) + _rotl(v[1], 7) + _rotl(v[2], 12) + _rotl(v[3], 18)) & M
        for lane in v:
            h = ((h ^ _round(0, lane)) * P1 + P4) & M
        h = (h + len(data)) & M
    for word in words[k:]:
        h = (_rotl(h ^ _round(0, word), 27) * P1 + P4) & M
    for b in data[8 * n:]:
        h = (_rotl(h ^ ((b * P5) & M), 11) * P1) & M
    h ^= h >> 33
    h = (h * P2) & M
    h ^= h >> 29
    h = (h * P3) & M
    h ^= h >> 32
    return h.to_bytes(8, "little")


@settings(max_examples=60, deadline=None)
@given(st.binary(min_size=0, max_size=200))
def test_it_is_its_definition_on_any_bytes(data):
    assert digest(np.frombuffer(data, np.uint8)) == _reference(data)


@settings(max_examples=60, deadline=None)
@given(st.binary(min_size=1, max_size=120), st.data())
def test_any_byte_changed_changes_it(data, draw):
    i = draw.draw(st.integers(0, len(data) - 1))
    b = draw.draw(st.integers(0, 255).filter(lambda v: v != data[i]))
    changed = data[:i] + bytes([b]) + data[i + 1:]
    assert digest(np.frombuffer(data, np.uint8)) != digest(np.frombuffer(changed, np.uint8))


def test_views_read_their_own_bytes_in_c_order_and_length_counts():
    a = np.arange(24.0).reshape(4, 6)
    assert digest(a[:, 1:]) == digest(np.ascontiguousarray(a[:, 1:])) != digest(a[:, :5])
    assert digest(a.T) == _reference(np.ascontiguousarray(a.T).tobytes()) != digest(a)
    assert digest(np.zeros(3, np.uint8)) != digest(np.zeros(4, np.uint8))
    assert digest(np.frombuffer(b"\x00" + a.tobytes(), np.uint8)[1:]) == digest(a)  # unaligned bytes
