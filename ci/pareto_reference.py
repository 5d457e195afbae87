"""Write the pareto stage's reference: the default pipeline's final fronts and what the stage made of them.

    python ci/pareto_reference.py   # after `dvc repro`; writes tests/data/pareto_reference/

Inputs are each source's final-round front from ``data/pareto/<algo>.parquet``; the expected merged and
selected tables are computed by the ``hevlib.pareto.select_designs`` of the checkout that runs this
script. The committed files were made by the pandas implementation (5d4e005), so
``tests/test_pareto_reference.py`` holds any later implementation to its tables.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import pyarrow.parquet as pq  # noqa: E402

from hevlib.params import load_params  # noqa: E402
from hevlib.pareto import select_designs, table_schema  # noqa: E402

OUT = ROOT / "tests" / "data" / "pareto_reference"


def main() -> None:
    params = load_params(ROOT / "params.yaml")
    algos = list(params.optimise.sources)
    fronts = {}
    (OUT / "fronts").mkdir(parents=True, exist_ok=True)
    for a in algos:
        table = pq.read_table(ROOT / "data" / "pareto" / f"{a}.parquet")
        df = table.to_pandas()
        last = df["round"] == df["round"].max()
        pq.write_table(table.filter(last.to_numpy()), OUT / "fronts" / f"{a}.parquet", compression="zstd")
        fronts[a] = df[last].drop(columns="round").reset_index(drop=True)
    res = select_designs(fronts, params.screen)
    for name, t in (("merged", res.merged), ("selected", res.selected)):
        import pyarrow as pa

        pq.write_table(
            pa.Table.from_pandas(t, schema=table_schema(t), preserve_index=False),
            OUT / f"{name}.parquet",
            compression="zstd",
        )
    print(f"{OUT}: {', '.join(algos)}; merged {len(res.merged)} rows, selected {len(res.selected)}")


if __name__ == "__main__":
    main()
