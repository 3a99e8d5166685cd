"""Build hook: compile durer's Numba kernels while the wheel is built, so the installed package carries their cache.

Numba caches compiled kernels in `__pycache__` beside each module, keyed by the source's content, the CPU and
the Numba version (not by path or time), so a cache filled in the build tree is found after installation on the
same machine: the first render then loads machine code instead of compiling for half a minute or more. The
warm-up (src/durer/warmup.py) runs in child processes on the build tree. Editable installs skip it (their
kernels compile in place on first use), and so does DURER_NO_WARMUP=1 (e.g. when building a wheel for another
machine, whose CPU may differ).
"""

import os
import sys

from setuptools import setup
from setuptools.command.build_py import build_py


class build_py_with_kernels(build_py):
    """build_py, then the kernel warm-up on the built package."""

    def run(self):
        super().run()
        if getattr(self, "editable_mode", False) or os.environ.get("DURER_NO_WARMUP") or self.dry_run:
            return
        build_lib = os.path.abspath(self.build_lib)
        env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}  # the cache must go in-tree
        env["PYTHONPATH"] = os.pathsep.join(p for p in (build_lib, env.get("PYTHONPATH")) if p)
        sys.path.insert(0, build_lib)
        try:
            from durer.warmup import warm_up

            seconds = warm_up(env=env)
        finally:
            sys.path.remove(build_lib)
        print(f"durer: kernels compiled and cached in {seconds:.0f} s", file=sys.stderr)


setup(cmdclass={"build_py": build_py_with_kernels})
