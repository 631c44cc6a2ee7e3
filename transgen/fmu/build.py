"""Compile a transgen FMU with the system C compiler and pack it, deterministically.

The FMI headers are the ones FMPy ships (``fmpy/c-code``; the optional extra ``transgen[fmu]``),
read from the installed package at build time, never copied into the repository. The FMU holds
``modelDescription.xml``, the shared library for this platform, and its C sources (the generated
tables and the runtime). The archive's entries are sorted with a fixed time stamp, and the
compiler gets no path that changes between runs: the same model gives the same bytes.
"""
from __future__ import annotations

import os
import platform
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from .data import FmuError

__all__ = ["fmi_headers", "find_compiler", "compile_library", "write_fmu", "platform_folder", "RUNTIME"]

RUNTIME = Path(__file__).with_name("c")
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)


def fmi_headers(fmi: int) -> Path:
    """The folder of the FMI ``fmi`` headers in the installed FMPy package."""
    try:
        import fmpy
    except ImportError:
        raise FmuError("the FMI headers come from the fmpy package, which is not installed: "
                       "pip install 'transgen[fmu]' (or pip install fmpy)") from None
    folder = Path(fmpy.__file__).parent / "c-code"
    header = folder / f"fmi{fmi}Functions.h"
    if not header.is_file():
        raise FmuError(f"the installed fmpy has no {header.name} in {folder}: reinstall fmpy")
    return folder


def find_compiler() -> str:
    """The C compiler: ``$CC``, else ``cc``, ``gcc`` or ``clang`` on the path."""
    names = [os.environ["CC"]] if os.environ.get("CC") else ["cc", "gcc", "clang"]
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    raise FmuError("no C compiler found (looked for " + ", ".join(names) + "): an FMU is compiled at export; "
                   "install one (e.g. 'apt-get install gcc', Xcode command line tools) or set CC")


def platform_folder(fmi: int) -> tuple[str, str]:
    """``(binaries sub-folder, library suffix)`` of this platform for FMI ``fmi``."""
    machine = platform.machine().lower()
    bits64 = sys.maxsize > 2 ** 32
    if sys.platform.startswith("linux"):
        system, suffix = "linux", ".so"
    elif sys.platform == "darwin":
        system, suffix = "darwin", ".dylib"
    elif sys.platform == "win32":
        system, suffix = "win", ".dll"
    else:
        raise FmuError(f"an FMU cannot be built on platform {sys.platform}")
    if fmi == 2:
        return f"{system}{64 if bits64 else 32}", suffix
    arch = {"amd64": "x86_64", "x86_64": "x86_64", "arm64": "aarch64", "aarch64": "aarch64"}.get(machine, machine)
    return f"{arch}-{'windows' if system == 'win' else system}", suffix


def compile_library(sources: dict[str, str], main: str, fmi: int, out: Path) -> None:
    """Compile the file ``main`` of ``sources`` (name -> text, written into a temporary folder)
    into the shared library ``out`` with the FMI ``fmi`` headers."""
    cc = find_compiler()
    headers = fmi_headers(fmi)
    with tempfile.TemporaryDirectory(prefix="transgen-fmu-") as tmp:
        for name, text in sources.items():
            Path(tmp, name).write_text(text)
        lib = Path(tmp, "model" + out.suffix)
        cmd = [cc, "-O2", "-shared", "-fPIC", "-fvisibility=hidden", "-std=c99", "-D_DEFAULT_SOURCE",
               f"-ffile-prefix-map={tmp}=.", f"-ffile-prefix-map={headers}=fmi", "-I", str(headers), "-I", tmp,
               "-o", str(lib), str(Path(tmp, main)), "-lm"]
        if sys.platform == "darwin":
            cmd.remove("-fvisibility=hidden")
        proc = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp)
        if proc.returncode != 0:
            raise FmuError(f"the C compiler {cc} failed on the generated FMU code:\n{proc.stderr.strip()[:4000]}")
        shutil.copyfile(lib, out)


def write_fmu(path: Path, files: dict[str, bytes]) -> None:
    """Write the archive ``path`` with ``files`` (archive name -> bytes), sorted, with a fixed
    time stamp, all or nothing (a temporary file renamed at the end)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".part")
    try:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            for name in sorted(files):
                info = zipfile.ZipInfo(name, _ZIP_TIME)
                info.compress_type = zipfile.ZIP_DEFLATED
                info.external_attr = 0o644 << 16
                z.writestr(info, files[name])
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
