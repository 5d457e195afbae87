"""The study's tables as polars frames: lazy Parquet scans, batched Parquet writes, the pandas edge.

Stages and library functions take any table (:data:`Table`: a polars ``DataFrame`` or ``LazyFrame``, or a
pandas ``DataFrame`` from a library that needs pandas) and work on a :func:`lazy` polars frame, collecting
only the columns a step needs, so a 10^6-design table never has all rows of every column in memory at
once. Parquet schemas stay explicit (pyarrow, units in the names): :func:`write_parquet_batches` writes a
stream of record batches through one ``pyarrow.parquet.ParquetWriter`` into a temp file renamed on
success (:func:`hevlib.io.atomic_path`), each batch converted by :func:`hevlib.io.to_arrow`.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import polars as pl
import pyarrow as pa
import pyarrow.parquet as pq

from hevlib.io import atomic_path, to_arrow

Table = pl.DataFrame | pl.LazyFrame | pd.DataFrame


def lazy(table: Table) -> pl.LazyFrame:
    """``table`` as a polars ``LazyFrame`` (pandas converted at this edge, without its index)."""
    if isinstance(table, pl.LazyFrame):
        return table
    if isinstance(table, pl.DataFrame):
        return table.lazy()
    if isinstance(table, pd.DataFrame):
        return pl.from_pandas(table.reset_index(drop=True)).lazy()
    raise TypeError(f"expected a polars or pandas table, got {type(table).__name__}")


def columns(table: Table) -> list[str]:
    """Column names, without reading a lazy table's rows."""
    return list(table.columns) if isinstance(table, pd.DataFrame | pl.DataFrame) else table.collect_schema().names()


def n_rows(table: Table) -> int:
    return (
        len(table) if isinstance(table, pd.DataFrame | pl.DataFrame) else int(table.select(pl.len()).collect().item())
    )


def matrix(table: Table, cols: Sequence[str]) -> np.ndarray:
    """The (n, len(cols)) float64 matrix of ``cols`` (only those columns are read); null -> NaN."""
    if isinstance(table, pd.DataFrame):
        return table[list(cols)].to_numpy(dtype=float)
    df = lazy(table).select([pl.col(c).cast(pl.Float64) for c in cols]).collect()
    return df.to_numpy().astype(float, copy=False).reshape(len(df), len(cols))


def scan(path: str | os.PathLike | Sequence[str | os.PathLike]) -> pl.LazyFrame:
    """A lazy scan of a Parquet file, of every ``*.parquet`` part in a folder, or of a list of files."""
    if isinstance(path, str | os.PathLike):
        p = Path(path)
        if p.is_dir():
            parts = sorted(p.glob("*.parquet"))
            if not parts:
                raise FileNotFoundError(f"{p}: no Parquet parts")
            return pl.scan_parquet([str(q) for q in parts])
        if not p.exists():
            raise FileNotFoundError(f"{p}: no such file")
        return pl.scan_parquet(str(p))
    return pl.scan_parquet([str(q) for q in path])


def write_parquet_batches(
    path: str | os.PathLike,
    batches: Iterable[Table | pa.Table | pa.RecordBatch],
    schema: pa.Schema,
    metadata: dict[str, str] | None = None,
) -> int:
    """Write ``batches`` (in order) to one Parquet file with ``schema``, one row group per batch, atomically;
    returns the number of rows. Only one batch is in memory at a time."""
    if metadata:
        meta = dict(schema.metadata or {})
        meta.update({k.encode(): str(v).encode() for k, v in metadata.items()})
        schema = schema.with_metadata(meta)
    rows = 0
    with atomic_path(path) as tmp, pq.ParquetWriter(tmp, schema) as writer:
        for batch in batches:
            table = to_arrow(batch, schema)
            writer.write_table(table.replace_schema_metadata(schema.metadata))
            rows += table.num_rows
    return rows


__all__ = ["Table", "lazy", "columns", "n_rows", "matrix", "scan", "write_parquet_batches"]
