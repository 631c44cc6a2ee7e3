"""Writing results to files: atomically, in JSON, NumPy ``.npz``, MATLAB ``.mat`` and LaTeX.

Every writer goes through :func:`atomic_path` (the output layer, :mod:`transgen.outputs`): the
data is written to a temporary file in the target's folder and renamed over the target only when
complete, so a failed run never leaves a half-written file; a device node or FIFO is written
through, a symbolic link followed, an input of the command refused.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .outputs import atomic_path, output_set
from .statespace import StateSpaceSet

__all__ = ["atomic_path", "output_set", "write_text", "write_json", "write_state_space", "state_space_latex",
           "matlab_name", "field_names", "output_format", "FORMATS", "SUFFIXES"]

FORMATS = ("json", "npz", "mat", "latex")

SUFFIXES = {".json": "json", ".npz": "npz", ".mat": "mat", ".tex": "latex"}
"""The format of a matrices file by its suffix."""


def output_format(path: str | Path, fmt: str | None = None, suffixes: dict[str, str] = SUFFIXES) -> str:
    """The format of the output ``path``: ``fmt`` (``--format``) or the one of its suffix. A
    ``fmt`` that another format's suffix contradicts (``--format mat -o x.npz``) is a ValueError:
    a file named ``.npz`` holding MATLAB data misleads every tool that opens it."""
    by_suffix = suffixes.get(Path(path).suffix.lower())
    if fmt is None:
        if by_suffix is None:
            raise ValueError(f"unknown format for {Path(path).name!r}: choose one of {', '.join(FORMATS)} "
                             f"(--format) or a {'/'.join(suffixes)} name")
        return by_suffix
    if fmt not in suffixes.values():
        raise ValueError(f"unknown format {fmt!r}: choose one of {', '.join(dict.fromkeys(suffixes.values()))}")
    if by_suffix is not None and by_suffix != fmt:
        want = next(k for k, v in suffixes.items() if v == fmt)
        raise ValueError(f"--format {fmt} and -o {path}: the name says {by_suffix}: name the file {want} "
                         f"(or leave --format out)")
    return fmt


def write_text(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (UTF-8)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_json(path: str | Path, data) -> None:
    """Write ``data`` as indented JSON atomically."""
    write_text(path, json.dumps(data, indent=2) + "\n")


def matlab_name(name: str) -> str:
    """A valid MATLAB identifier for ``name`` (a mode or signal name): characters other than
    ASCII letters, digits and ``_`` become ``_``, and a name not starting with a letter gets
    ``m_``; at most :data:`MATLAB_NAME_LENGTH` characters."""
    out = "".join(ch if (ch.isascii() and ch.isalnum()) or ch == "_" else "_" for ch in name)
    out = out if out[:1].isascii() and out[:1].isalpha() else f"m_{out}"
    return out[:MATLAB_NAME_LENGTH]


MATLAB_NAME_LENGTH = 63
"""The longest MATLAB identifier (``namelengthmax``)."""


def field_names(names) -> list[str]:
    """The field name of each of ``names`` (mode names) in ``.mat`` and ``.npz`` files: its
    :func:`matlab_name`, made unique (``_2``, ``_3``, ... where two names give the same one).
    Every file that renames stores the map beside the names (``fields``), so that
    ``M.(M.fields{k})`` in MATLAB/Octave is the mode ``M.modes{k}``."""
    out: list[str] = []
    for name in names:
        base = field = matlab_name(name)
        k = 1
        while field in out:
            k += 1
            field = f"{base[:MATLAB_NAME_LENGTH - len(str(k)) - 1]}_{k}"
        out.append(field)
    return out


def _float(x) -> np.ndarray:
    return np.asarray(x.evalf() if hasattr(x, "evalf") else x, dtype=float)


def write_state_space(ss: StateSpaceSet, path: str | Path, fmt: str | None = None) -> None:
    """Write a :class:`StateSpaceSet` as ``json``, ``npz``, ``mat`` or ``latex`` (by suffix).

    Every mode has the matrices ``A``, ``B``, ``C_speeds``, ``D_torques`` and the stacked
    ``Cy = [C_speeds; 0]``, ``Dy = [0; D_torques]`` (outputs ``y = [w; t]``, see
    :mod:`transgen.statespace`), with the names of its ``states``, ``inputs`` and ``outputs``:

    * ``json``: a ``transgen.matrices/1`` document (:func:`~transgen.statespace.matrices_document`):
      ``{"mechanism", "coordinates", "inputs", "modes": [{"name", "gear", "locked", "dof", "states",
      "inputs", "outputs", "A", "B", "C_speeds", "D_torques", "Cy", "Dy", ...}], "skipped"}``;
    * ``npz``: arrays ``<field>_A``, ``<field>_B``, ... ``<field>_Dy`` (``field``: the mode's
      field name, :func:`field_names`) and the JSON document without the matrices in ``meta``
      (each mode with its ``field``, and ``fields``: name -> field);
    * ``mat``: a MATLAB struct per mode, named by its field (``M1.A``, ..., ``M1.Cy``, ``M1.Dy``,
      ``M1.states``, ``M1.inputs``, ``M1.outputs``, ``M1.gear`` (the gear it is, or empty), ``M1.locked``,
      ``M1.locked_groups``, ``M1.dof`` a double,
      ...), the cell arrays ``modes`` (the names) and ``fields`` (``M.(M.fields{k})`` is mode
      ``M.modes{k}``), ``labels``, ``inputs``, ``coordinates``, ``skipped`` (structs: name,
      locked, kind, problem) and the JSON's ``schema``, ``units`` (a struct) and
      ``transgen_version``: ``ss(M1.A, M1.B, M1.Cy, M1.Dy)`` in MATLAB/Octave;
      ``scipy.io.loadmat`` reads it;
    * ``latex``: one ``align*`` block per mode, ``\\dot x = B u``, ``w = C_speeds x``,
      ``t = D_torques u`` (``array`` environments: any number of columns).

    Symbolic matrices are written as expressions in JSON and LaTeX; ``npz`` and ``mat`` need
    numbers and refuse symbolic input.
    """
    from .statespace import MATRICES, MATRICES_SCHEMA, MATRICES_UNITS, matrices_document

    path = Path(path)
    fmt = output_format(path, fmt)
    if ss.symbolic and fmt in ("npz", "mat"):
        raise ValueError(f"{fmt} holds numbers only: write symbolic matrices as json or latex")
    if fmt == "json":
        write_json(path, matrices_document(ss))
    elif fmt == "latex":
        write_text(path, state_space_latex(ss))
    elif fmt == "npz":
        fields = field_names(m.name for m in ss.modes)
        arrays = {f"{f}_{k}": _float(getattr(m, k)) for m, f in zip(ss.modes, fields) for k in MATRICES}
        meta = matrices_document(ss)
        meta["modes"] = [{k: v for k, v in d.items() if k not in MATRICES} | {"field": f}
                         for d, f in zip(meta["modes"], fields)]
        meta["fields"] = dict(zip((m.name for m in ss.modes), fields))
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as f:
                np.savez(f, meta=np.array(json.dumps(meta)), **arrays)
    else:
        import scipy.io

        from . import __version__

        def cells(names):
            return np.array(list(names), dtype=object)

        fields = field_names(m.name for m in ss.modes)
        data = {
            "schema": MATRICES_SCHEMA, "mechanism": ss.mechanism, "transgen_version": __version__,
            "units": dict(MATRICES_UNITS), "symbolic": False,
            "coordinates": cells(ss.coordinates), "inputs": cells(ss.inputs), "modes": cells(m.name for m in ss.modes),
            "fields": cells(fields), "labels": cells(m.label or "" for m in ss.modes),
            "skipped": _skipped_cells(ss.skipped),
        }
        for m, field in zip(ss.modes, fields):
            data[field] = {
                "name": m.name, "field": field, "gear": m.gear or "", "label": m.label or "", "kind": m.kind,
                "dof": float(m.dof),
                "locked": cells(m.locked), "states": cells(m.states), "inputs": cells(m.inputs),
                "outputs": cells(m.outputs), **{k: _float(getattr(m, k)) for k in MATRICES},
                "speed_outputs": cells(m.speed_outputs), "torque_outputs": cells(m.torque_outputs),
                "locked_groups": _nested_cells(m.locked_groups),
            }
        with atomic_path(path) as tmp:
            scipy.io.savemat(str(tmp), data, oned_as="column")


def _nested_cells(groups) -> np.ndarray:
    """A cell array of cell arrays of names (a mode's locked groups) for ``scipy.io.savemat``."""
    out = np.empty(len(groups), dtype=object)
    for i, grp in enumerate(groups):
        out[i] = np.array(list(grp), dtype=object)
    return out


def _skipped_cells(skipped) -> np.ndarray:
    """The skipped combinations as a cell array of structs (name, locked, kind, problem)."""
    out = np.empty(len(skipped), dtype=object)
    for i, m in enumerate(skipped):
        out[i] = {"name": m.name, "locked": np.array(list(m.locked), dtype=object), "kind": m.kind,
                  "problem": m.problem}
    return out


def _latex_matrix(x, symbolic: bool) -> str:
    if symbolic:
        import sympy

        return sympy.latex(x, mat_delim="(", mat_str="array")  # \left(\begin{array}{cc...}
    a = _float(x)
    if a.size == 0:
        return r"\emptyset"
    return _array([[f"{v:.6g}" for v in row] for row in a])


def _array(rows: list[list[str]]) -> str:
    """A parenthesised ``array``: unlike ``pmatrix`` (amsmath's ``MaxMatrixCols``, 10) it takes
    any number of columns, e.g. the inputs of a mechanism with many shift elements."""
    spec = "c" * max(map(len, rows), default=1)
    return rf"\left(\begin{{array}}{{{spec}}}" + r" \\ ".join(" & ".join(r) for r in rows) + r"\end{array}\right)"


def _vec(names) -> str:
    return _array([[_tex_name(n)] for n in names])


def _tex_name(name: str) -> str:
    head, _, tail = name.partition("_")
    if not tail:
        return rf"\mathrm{{{head}}}"
    tail = tail.replace("_", r"\_")
    return rf"\mathrm{{{head}}}_{{\mathrm{{{tail}}}}}"


def state_space_latex(ss: StateSpaceSet) -> str:
    """LaTeX (``align*`` per mode) of the state-space matrices, for reports."""
    out = [f"% state-space matrices of {ss.mechanism}, generated by transgen",
           f"% coordinates: {', '.join(ss.coordinates)}; inputs u = ({', '.join(ss.inputs)})"]
    for m in ss.modes:
        locked = ", ".join(m.locked) or "none"
        gear = f"gear {m.gear}; " if m.gear is not None and f"gear {m.gear}" not in m.label else ""
        out.append(f"\\paragraph{{Mode {m.name} ({gear}{m.label or 'mode'}; locked: {locked}; {m.dof} DOF)}}")
        out.append(r"\begin{align*}")
        x = [f"w_{s}" for s in m.states]
        u = list(m.inputs)
        lines = []
        if x:
            lines.append(rf"\frac{{d}}{{dt}}{_vec(x)} &= {_latex_matrix(m.B, ss.symbolic)} {_vec(u)}")
            lines.append(rf"{_vec([f'w_{s}' for s in m.speed_outputs])} &= {_latex_matrix(m.C, ss.symbolic)} {_vec(x)}")
        if m.torque_outputs:
            lines.append(rf"{_vec(m.torque_outputs)} &= {_latex_matrix(m.D, ss.symbolic)} {_vec(u)}")
        out.append(" \\\\\n".join(lines) if lines else r"\text{no state, no locked element}")
        out.append(r"\end{align*}")
    return "\n".join(out) + "\n"
