"""``snakeplan bench``: the benchmarks, one sub-parser each: speed (:mod:`.bench_speed`: kernels, speed, mesh, rl),
paper 000's Table 2 (:mod:`.bench_table2`), the runner and its reports (:mod:`.bench_run`: run, report) and the
papers' other figures (:mod:`.bench_papers`: station, ablation, sscc) and inspection of any scene
(:mod:`.bench_inspect`)."""

from __future__ import annotations

from snakeplan.commands import bench_inspect, bench_papers, bench_run, bench_speed, bench_table2
from snakeplan.commands.common import Parser


def add_parser(sub) -> None:
    bench = sub.add_parser("bench", help="benchmarks: run, report, kernels, speed, mesh, table2, station, sscc, rl, "
                           "ablation, inspect",
                           description="Benchmarks that reproduce the papers' figures and measure speed.")
    bsub = bench.add_subparsers(dest="bench", required=True, parser_class=Parser, metavar="BENCH")
    bench_speed.add_parsers(bsub)
    bench_table2.add_parser(bsub)
    bench_run.add_parsers(bsub)
    bench_papers.add_parsers(bsub)
    bench_inspect.add_parser(bsub)
