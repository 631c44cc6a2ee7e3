"""The resumable checkpoint of ``transgen synthesize topology -o DIR``: the finished gear trains.

``DIR/topology_checkpoint.json`` (schema ``transgen.synthesize.topology.checkpoint/1``) holds the
request, the number of gear trains, and per finished train (its index in the fixed order of
:func:`transgen.synthesis.topology.trains`) the stage counts and the fitted concepts (links by
index, ``k`` and the errors as JSON numbers, which read back to the same floats). It is rewritten
atomically (:func:`transgen.outputs.atomic_path`) at most every ``interval`` seconds and at the
end; a run that is stopped resumes from it and skips the trains done: the merged result is the
same as without the interruption.
"""
from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

from ..errors import TransgenError
from .fit import Fit
from .search import FittedConcept, SearchSpec, TrainResult
from .topology import Concept

__all__ = ["CHECKPOINT", "SCHEMA", "Checkpoint", "CheckpointError"]

CHECKPOINT = "topology_checkpoint.json"
SCHEMA = "transgen.synthesize.topology.checkpoint/1"
COUNTS = ("enumerated", "distinct", "feasible", "screened", "refined", "fitted")


class CheckpointError(TransgenError, ValueError):
    """A checkpoint that is unreadable or written for another search (exit 2)."""


def _spec_record(spec: SearchSpec) -> dict:
    return json.loads(json.dumps(dataclasses.asdict(spec)))


def _result_record(result: TrainResult) -> dict:
    return {**{c: getattr(result, c) for c in COUNTS},
            "concepts": [{"input": f.concept.input, "output": f.concept.output, "brakes": list(f.concept.brakes),
                          "clutches": [list(c) for c in f.concept.clutches], "k": list(f.fit.k),
                          "assignment": list(f.fit.assignment), "ratios": list(f.fit.ratios),
                          "errors": list(f.fit.errors), "gears": [list(g) for g in f.gears]}
                         for f in result.concepts]}


def _result_of(record: dict, train) -> TrainResult:
    out = TrainResult(**{c: int(record[c]) for c in COUNTS})
    for c in record["concepts"]:
        concept = Concept(train, int(c["input"]), int(c["output"]), tuple(int(b) for b in c["brakes"]),
                          tuple((int(a), int(b)) for a, b in c["clutches"]))
        fit = Fit(tuple(float(x) for x in c["k"]), tuple(int(a) for a in c["assignment"]),
                  tuple(float(x) for x in c["ratios"]), tuple(float(x) for x in c["errors"]))
        out.concepts.append(FittedConcept(concept, fit, tuple(tuple(g) for g in c["gears"])))
    return out


class Checkpoint:
    """The finished trains of one search in ``folder`` (read at creation when the file exists)."""

    def __init__(self, folder: str | Path, spec: SearchSpec, all_trains: list, interval: float = 30.0):
        self.path = Path(folder) / CHECKPOINT
        self.spec = spec
        self.trains = all_trains
        self.interval = interval
        self.records: dict[int, dict] = {}
        self.done: dict[int, TrainResult] = {}
        self._written = time.monotonic()
        if self.path.exists():
            self._read()

    def _read(self) -> None:
        where = f"{self.path}:1:1: error:"
        try:
            doc = json.loads(self.path.read_text())
        except (OSError, ValueError) as exc:
            raise CheckpointError(f"{where} unreadable checkpoint ({exc}); remove it to start again") from None
        if not isinstance(doc, dict) or doc.get("schema") != SCHEMA:
            raise CheckpointError(f"{where} not a {SCHEMA} file; remove it or choose another -o")
        if doc.get("request") != _spec_record(self.spec) or doc.get("trains") != len(self.trains):
            raise CheckpointError(f"{where} written for another search ({doc.get('request')}); remove it or "
                                  f"choose another -o")
        try:
            self.records = {int(i): r for i, r in doc["done"].items()}
            self.done = {i: _result_of(r, self.trains[i]) for i, r in self.records.items()}
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise CheckpointError(f"{where} damaged checkpoint ({exc!r}); remove it to start again") from None

    def add(self, index: int, result: TrainResult) -> None:
        """Record train ``index`` as finished; write the file when ``interval`` has passed."""
        self.records[index] = _result_record(result)
        if time.monotonic() - self._written >= self.interval:
            self.save()

    def save(self) -> None:
        """Write the file now (atomically: a reader sees the old or the new one, whole)."""
        from ..outputs import atomic_path

        doc = {"schema": SCHEMA, "request": _spec_record(self.spec), "trains": len(self.trains),
               "done": {str(i): self.records[i] for i in sorted(self.records)}}
        with atomic_path(self.path) as tmp:
            Path(tmp).write_text(json.dumps(doc, separators=(",", ":")) + "\n")
        self._written = time.monotonic()
