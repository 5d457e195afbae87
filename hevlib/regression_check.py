"""Metric regression check: a fresh run's metrics against a committed baseline, per-metric tolerances.

Metrics are the pipeline's JSON reports (flattened like ``dvc metrics show``: ``prius.ftp.fc``). The
tolerance file (YAML) maps a metrics file (a glob relative to the reports folder) to rules, each a
metric pattern (``fnmatch`` on the dotted key) with ``abs`` and/or ``rel`` tolerance; the first rule
that matches a key guards it, keys no rule matches are shown but not guarded::

    baselines.json:
      "*.ftp.fc": {rel: 0.002}          # physics: tight
    optimise_*.json:
      hypervolume: {rel: 0.5, abs: 0.01}  # stochastic: loose

A guarded metric fails when ``|new - old| > max(abs, rel * |old|)``, when it disappears, or when it
turns non-numeric. Booleans must match exactly.
"""

from __future__ import annotations

import fnmatch
import json
import math
from dataclasses import dataclass
from pathlib import Path

from hevlib.io import read_yaml_mapping


@dataclass(frozen=True)
class Rule:
    pattern: str
    abs_tol: float = 0.0
    rel_tol: float = 0.0

    def allows(self, old: float, new: float) -> bool:
        return abs(new - old) <= max(self.abs_tol, self.rel_tol * abs(old)) + 1e-12

    def describe(self) -> str:
        parts = [f"{name} {tol:g}" for name, tol in (("abs", self.abs_tol), ("rel", self.rel_tol)) if tol]
        return " / ".join(parts) or "exact"


@dataclass(frozen=True)
class Row:
    file: str
    key: str
    old: object
    new: object
    rule: Rule | None
    ok: bool

    @property
    def change(self) -> float | None:
        if _is_number(self.old) and _is_number(self.new):
            return float(self.new) - float(self.old)
        return None


def _is_number(x) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def flatten(obj, prefix: str = "") -> dict[str, object]:
    """Nested JSON -> {dotted key: scalar}; lists are indexed (``a.0.b``)."""
    out: dict[str, object] = {}
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else None
    if items is None:
        return {prefix: obj}
    for k, v in items:
        out.update(flatten(v, f"{prefix}.{k}" if prefix else str(k)))
    return out


def load_tolerances(path: str | Path) -> dict[str, list[Rule]]:
    """File glob -> ordered rules; a malformed file fails with one line naming the entry."""
    data = read_yaml_mapping(path, what="tolerance file (metrics files to rules)", empty_ok=True)
    rules: dict[str, list[Rule]] = {}
    for file_glob, entries in data.items():
        if not isinstance(entries, dict):
            raise ValueError(f"{path}: {file_glob}: must map metric patterns to tolerances")
        rules[file_glob] = []
        for pattern, tol in entries.items():
            tol = tol or {}
            valid = all(isinstance(tol.get(k, 0), int | float) and tol.get(k, 0) >= 0 for k in ("abs", "rel"))
            if set(tol) - {"abs", "rel"} or not valid:
                raise ValueError(f"{path}: {file_glob}: {pattern}: tolerance must be {{abs: >=0, rel: >=0}}")
            rules[file_glob].append(Rule(str(pattern), float(tol.get("abs", 0.0)), float(tol.get("rel", 0.0))))
    return rules


def _rule_for(file: str, key: str, rules: dict[str, list[Rule]]) -> Rule | None:
    for file_glob, entries in rules.items():
        if fnmatch.fnmatch(file, file_glob):
            for rule in entries:
                if fnmatch.fnmatchcase(key, rule.pattern):
                    return rule
    return None


def compare(baseline_dir: str | Path, current_dir: str | Path, rules: dict[str, list[Rule]]) -> list[Row]:
    """Every metric of every baseline JSON file against the current run's file of the same name."""
    baseline_dir, current_dir = Path(baseline_dir), Path(current_dir)
    files = sorted(p.name for p in baseline_dir.glob("*.json"))
    if not files:
        raise FileNotFoundError(f"{baseline_dir}: no baseline metrics (*.json)")
    rows: list[Row] = []
    for name in files:
        old = flatten(json.loads((baseline_dir / name).read_text()))
        cur_path = current_dir / name
        new = flatten(json.loads(cur_path.read_text())) if cur_path.exists() else {}
        for key in sorted(set(old) | set(new)):
            rule = _rule_for(name, key, rules)
            o, n = old.get(key), new.get(key)
            if rule is None:
                ok = True
            elif key not in new:
                ok = False
            elif isinstance(o, bool) or isinstance(n, bool) or not (_is_number(o) and _is_number(n)):
                ok = o == n
            else:
                ok = rule.allows(float(o), float(n))
            rows.append(Row(name, key, o, n, rule, ok))
    return rows


def _fmt(x) -> str:
    if x is None:
        return "-"
    if _is_number(x):
        return f"{x:.6g}"
    return str(x)


def table(rows: list[Row], *, all_rows: bool = False) -> str:
    """A ``dvc metrics diff``-style table: guarded metrics (and changed unguarded ones, or all)."""
    shown = [r for r in rows if all_rows or r.rule is not None or (r.change not in (None, 0.0)) or r.old != r.new]
    head = ("Path", "Metric", "Old", "New", "Change", "Tolerance", "Status")
    body = [
        (
            r.file,
            r.key,
            _fmt(r.old),
            _fmt(r.new),
            _fmt(r.change),
            r.rule.describe() if r.rule else "-",
            ("ok" if r.ok else "REGRESSION") if r.rule else "unguarded",
        )
        for r in shown
    ]
    widths = [max(len(str(x)) for x in col) for col in zip(head, *body, strict=False)]
    line = "  ".join
    return "\n".join(
        [line(h.ljust(w) for h, w in zip(head, widths, strict=True))]
        + [line(c.ljust(w) for c, w in zip(row, widths, strict=True)) for row in body]
    )
