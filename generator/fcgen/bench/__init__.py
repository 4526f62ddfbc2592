"""``fcgen bench``: the closed-loop benchmark of a generated solver (``host``: the optimized C build vs the Python
reference), its instruction counts on an emulated target (``target``) and several QP backends compared
(``backends``)."""

from .backends import BACKEND_VARIANTS, bench_backends, format_backends, parse_backends, variant_qp
from .host import STAT_KEYS, TIME_KEYS, aggregate, bench, format_bench, write_results
from .target import bench_target, format_bench_target

__all__ = [
    "BACKEND_VARIANTS",
    "STAT_KEYS",
    "TIME_KEYS",
    "aggregate",
    "bench",
    "bench_backends",
    "bench_target",
    "format_backends",
    "format_bench",
    "format_bench_target",
    "parse_backends",
    "variant_qp",
    "write_results",
]
