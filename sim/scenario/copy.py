"""Copying a scenario with the files it includes, so that the copy runs as it is.

A bundled scenario names shared parameter files (``include = ["shared/m915_truck.toml"]``);
copying the file alone breaks the include. :func:`copy_scenario` writes the scenario and every
file it includes, directly or through another include, in the same layout relative to the
scenario's folder. Mechanisms named by a bundled name stay bundled; everything is written
together or not at all, and existing files are kept unless ``force``.
"""
from __future__ import annotations

from pathlib import Path

from transgen.errors import ScenarioError

from .file import Source, read_source

__all__ = ["copy_scenario", "included_files"]


def included_files(path: str | Path) -> list[Path]:
    """The scenario file ``path`` and every file it includes (directly or not), resolved, each once."""
    _, source = read_source(Path(path))
    out: list[Path] = []

    def walk(s: Source) -> None:
        p = s.path.resolve()
        if p not in out:
            out.append(p)
        for inc in s.includes:
            walk(inc)

    walk(source)
    return out


def copy_scenario(name: str | Path, directory: str | Path, force: bool = False) -> list[Path]:
    """Write the scenario ``name`` (a bundled name or a scenario file) and its included files into
    ``directory``, in the same layout relative to the scenario's folder; returns the written paths.

    Raises
    ------
    ScenarioError
        If a file to write exists (and not ``force``), or an include lies outside the scenario's
        folder (a copy could not keep its layout). Nothing is written then.
    """
    from transgen.export import output_set, write_text

    from .load import scenario_path

    path = scenario_path(name)
    root = path.parent.resolve()
    directory = Path(directory)
    plan = []
    for f in included_files(path):
        try:
            rel = f.relative_to(root)
        except ValueError:
            raise ScenarioError(f"{path}:1:1: error: the included file {f} is outside the scenario's folder "
                                f"{root}; copy it by hand") from None
        plan.append((f, directory / rel))
    existing = [str(t) for _, t in plan if t.exists()]
    if existing and not force:
        raise ScenarioError(f"{', '.join(existing)} exist{'s' if len(existing) == 1 else ''} already "
                            f"(use --force to overwrite)")
    with output_set():
        for f, target in plan:
            write_text(target, f.read_text(encoding="utf-8"))
    return [t for _, t in plan]
