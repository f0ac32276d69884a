"""Build the C reference firmware (``firmware_model/c/*.c``) on the host with cffi and load it.

The C sources are portable C99 (``int32_t``/``int64_t``, explicit shifts, rounding and saturation); every
header marks the declarations Python may call between ``/* cdef-begin */`` and ``/* cdef-end */`` (plain C
declarations cffi can parse, no preprocessor lines).  :func:`load` compiles all sources into one extension
module, cached under ``~/.cache/nodesim/c_reference/<hash of the sources>`` (or ``$NODESIM_C_CACHE``), and
returns ``(ffi, lib)``.  cffi is a test dependency (the ``test`` extra): the simulator never needs it.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import sys
from pathlib import Path

from firmware_model.errors import FirmwareError

C_DIR = Path(__file__).with_name("c")
CFLAGS = ["-std=c99", "-O2", "-Wall", "-Werror", "-fwrapv"]
LDLIBS = ["-lm"]  # survey.c's float32 ("fpu") mode: atan2f, sqrtf, rintf
_CDEF = re.compile(r"/\* cdef-begin \*/(.*?)/\* cdef-end \*/", re.S)
_LOADED: dict[str, tuple] = {}


def sources() -> list[Path]:
    """The C files of the reference firmware, in a fixed order."""
    return sorted(C_DIR.glob("*.c"))


def headers() -> list[Path]:
    return sorted(C_DIR.glob("*.h"))


def cdefs() -> str:
    """The callable declarations of every header (the text between the cdef markers)."""
    return "\n".join(m.group(1) for h in headers() for m in _CDEF.finditer(h.read_text()))


def _digest() -> str:
    h = hashlib.sha256()
    for p in headers() + sources():
        h.update(p.name.encode() + b"\0" + p.read_bytes() + b"\0")
    h.update(" ".join(CFLAGS).encode())
    return h.hexdigest()[:16]


def _cache_dir() -> Path:
    root = os.environ.get("NODESIM_C_CACHE") or str(Path.home() / ".cache" / "nodesim" / "c_reference")
    return Path(root)


def load():
    """(ffi, lib) of the compiled C reference (compiled once per source version)."""
    key = _digest()
    if key not in _LOADED:
        _LOADED[key] = _build(key, C_DIR, _cache_dir() / key)
    return _LOADED[key]


def load_modified(replacements: dict[str, tuple[str, str]], tmpdir: Path):
    """(ffi, lib) of a copy of the C reference in ``tmpdir`` with ``replacements`` {file name: (old, new)}
    applied (each ``old`` must occur): the tests' deliberately broken builds."""
    tmpdir = Path(tmpdir)
    tmpdir.mkdir(parents=True, exist_ok=True)
    for p in headers() + sources():
        text = p.read_text()
        if p.name in replacements:
            old, new = replacements[p.name]
            if old not in text:
                raise FirmwareError(f"{p.name}: the text to replace does not occur: {old!r}")
            text = text.replace(old, new)
        (tmpdir / p.name).write_text(text)
    key = "mod" + hashlib.sha256(repr(sorted(replacements.items())).encode()).hexdigest()[:12]
    return _build(key, tmpdir, tmpdir / "build")


def _build(key: str, src_dir: Path, out: Path):
    try:
        import cffi
    except ImportError as e:  # pragma: no cover - the test extra installs it
        raise FirmwareError("the C reference needs cffi: pip install 'nodesim[test]'") from e
    name = f"_nodesim_cref_{key}"
    out.mkdir(parents=True, exist_ok=True)
    built = sorted(out.glob(f"{name}*.so"))
    if not built:
        ffi = cffi.FFI()
        ffi.cdef(cdefs())
        hdrs = sorted(src_dir.glob("*.h"))
        includes = "".join(f'#include "{h.name}"\n' for h in hdrs)
        ffi.set_source(name, includes, sources=[str(s) for s in sorted(src_dir.glob("*.c"))],
                       include_dirs=[str(src_dir)], extra_compile_args=CFLAGS,
                       libraries=[f[2:] for f in LDLIBS])
        ffi.compile(tmpdir=str(out), verbose=False)
        built = sorted(out.glob(f"{name}*.so"))
    spec = importlib.util.spec_from_file_location(name, built[0])
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module.ffi, module.lib
