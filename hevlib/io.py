"""Artifact I/O: every write goes to a temp file in the target folder, then an atomic rename."""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import yaml

if TYPE_CHECKING:  # imported where used: `hev` validates params before a stage loads pandas, polars, pyarrow
    import pandas as pd
    import polars as pl
    import pyarrow as pa

_UMASK = os.umask(0)
os.umask(_UMASK)


@contextmanager
def atomic_path(path: str | os.PathLike):
    """Yield a temp path beside ``path``; rename onto ``path`` only if the block succeeds."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp creates 0600; outputs get the usual permissions
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


#: Significant digits of every float written to a JSON report.
JSON_SIGNIFICANT_DIGITS = 12


def _jsonable(obj, digits: int | None = JSON_SIGNIFICANT_DIGITS):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v, digits) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v, digits) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, np.ndarray):
        return [_jsonable(v, digits) for v in obj.tolist()]
    if isinstance(obj, float):
        if not np.isfinite(obj):
            return None
        # reports: 12 significant digits, far below any tolerance and above the last-bit noise of threaded
        # reductions, so a report (a DVC metric, in git) has the same bytes whenever its inputs are the same
        return float(f"{obj:.{digits}g}") if digits else obj
    return obj


def finite_or_none(x) -> float | None:
    """``x`` as a float, or None where it is missing or not finite (a report's null)."""
    if x is None:
        return None
    x = float(x)
    return x if np.isfinite(x) else None


def write_json(path: str | os.PathLike, data: dict, *, digits: int | None = JSON_SIGNIFICANT_DIGITS) -> None:
    """Write ``data`` as indented JSON (NaN/inf as null), atomically; floats to ``digits`` significant
    digits (``None``: exact, for data that must round-trip)."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(_jsonable(data, digits), indent=2, sort_keys=False) + "\n")


def write_text(path: str | os.PathLike, text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def to_arrow(
    table: pd.DataFrame | pl.DataFrame | pl.LazyFrame | pa.Table | pa.RecordBatch, schema: pa.Schema | None = None
) -> pa.Table:
    """Any table as a pyarrow table, with exactly ``schema`` (column order included) when given."""
    import pandas as pd
    import polars as pl
    import pyarrow as pa

    if isinstance(table, pd.DataFrame):
        return pa.Table.from_pandas(table, schema=schema, preserve_index=False)
    if isinstance(table, pa.RecordBatch):
        table = pa.Table.from_batches([table])
    if isinstance(table, pl.LazyFrame):
        table = table.collect()
    if isinstance(table, pl.DataFrame):
        table = (table if schema is None else table.select(schema.names)).to_arrow()
    return table if schema is None else table.select(schema.names).cast(schema)


def write_parquet(
    path: str | os.PathLike,
    table: pd.DataFrame | pl.DataFrame | pl.LazyFrame | pa.Table,
    schema: pa.Schema | None = None,
    metadata: dict[str, str] | None = None,
) -> None:
    """Write a Parquet file with an explicit schema (columns must match it exactly)."""
    import pyarrow.parquet as pq

    table = to_arrow(table, schema)
    if metadata:
        meta = dict(table.schema.metadata or {})
        meta.update({k.encode(): str(v).encode() for k, v in metadata.items()})
        table = table.replace_schema_metadata(meta)
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)


def save_with(path: str | os.PathLike, writer: Callable[[Path], None]) -> None:
    """Atomically write ``path`` with a callable that writes to the temp path it gets (plots, torch)."""
    with atomic_path(path) as tmp:
        writer(tmp)


class UniqueKeyLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses a mapping with the same key twice (YAML leaves it to the loader;
    PyYAML keeps the last, silently)."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r} (line {key_node.start_mark.line + 1})", key_node.start_mark
                )
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


def read_yaml_mapping(
    path: str | os.PathLike,
    *,
    what: str,
    error: type[Exception] = ValueError,
    missing_error: type[Exception] = FileNotFoundError,
    empty_ok: bool = False,
) -> dict:
    """A YAML file whose top level is a mapping, with one-line errors naming the file (``what``: what
    the file is, for the messages). ``empty_ok``: an empty file reads as ``{}``."""
    path = Path(path)
    if not path.exists():
        raise missing_error(f"{path}: no such {what}")
    try:
        data = yaml.load(path.read_text(), Loader=UniqueKeyLoader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.YAMLError as err:
        raise error(f"{path}: not valid YAML ({str(err).splitlines()[0]})") from None
    if data is None and empty_ok:
        return {}
    if not isinstance(data, dict):
        raise error(f"{path}: top level must be a mapping ({what})")
    return data


def write_table(path: str | os.PathLike, table: pd.DataFrame, *, float_format: str | None = None) -> None:
    """Write a CSV or Parquet table (by extension), atomically; ``float_format`` applies to CSV."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".csv":
        with atomic_path(path) as tmp:
            table.to_csv(tmp, index=False, float_format=float_format)
    elif suffix in (".parquet", ".pq"):
        write_parquet(path, table)
    else:
        raise ValueError(f"{path}: unsupported table format (use .csv or .parquet)")


def read_table(path: str | os.PathLike) -> pd.DataFrame:
    """Read a CSV or Parquet table, naming the file in any error."""
    import pandas as pd
    import pyarrow as pa

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file")
    try:
        if path.suffix.lower() == ".csv":
            return pd.read_csv(path)
        if path.suffix.lower() in (".parquet", ".pq"):
            return pd.read_parquet(path)
    except pd.errors.EmptyDataError:
        raise ValueError(f"{path}: empty file (no header, no rows)") from None
    except (pd.errors.ParserError, UnicodeDecodeError, pa.ArrowInvalid) as err:
        raise ValueError(f"{path}: not a readable table ({str(err).strip().splitlines()[0]})") from None
    raise ValueError(f"{path}: unsupported table format (use .csv or .parquet)")


def float_schema(columns: list[str], extra: list[pa.Field] | None = None) -> pa.Schema:
    """A schema of float64 columns in the given order, plus any extra typed fields."""
    import pyarrow as pa

    return pa.schema([pa.field(c, pa.float64()) for c in columns] + list(extra or []))
