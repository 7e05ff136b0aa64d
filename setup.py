"""The package's C code (circuitnsds/native.py): compiled at install when a C compiler is
there, skipped (with pip's warning) when not; the package then runs its loops compiled by
numba and its dense LU by scipy's LAPACK.

Everything else about the package is in pyproject.toml."""

import sys
import zlib
from pathlib import Path

from setuptools import Extension, setup

NATIVE = ("circuitnsds/engine/_dense_native", "circuitnsds/engine/exact/_exact_native",
          "circuitnsds/output/_floattext_native",
          "circuitnsds/output/_raster_native", "circuitnsds/solvers/_lu_native")
"""The C sources (without .c), each built into a library beside it."""

# the same floating-point arithmetic as the Python and numba loops: no fused multiply-adds,
# no reassociation (gcc and clang; MSVC's defaults are strict already)
FLAGS = [] if sys.platform == "win32" else ["-O2", "-ffp-contract=off", "-fno-fast-math"]


HEADER = Path("circuitnsds/native.h")
"""The header every library includes (its export macro and digest function)."""


def extension(stem: str) -> Extension:
    source = Path(stem + ".c")
    # as circuitnsds.native.source_digest: CRC-32 and length of the .c file's bytes, then the header's
    content = source.read_bytes() + HEADER.read_bytes()
    digest = f"{zlib.crc32(content):08x}-{len(content)}"
    return Extension(stem.replace("/", "."), [str(source)], optional=True, extra_compile_args=FLAGS,
                     include_dirs=[str(HEADER.parent)], depends=[str(HEADER)],
                     define_macros=[("CIRCUITNSDS_SOURCE_DIGEST", f'"{digest}"')])


setup(ext_modules=[extension(stem) for stem in NATIVE if Path(stem + ".c").is_file()])
