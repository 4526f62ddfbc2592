"""MISRA C:2012 deviations of the emitted solver (``<name>_solver.c`` / ``<name>_solver.h``).

cppcheck's MISRA addon finds nothing else in those two files; the tests check that its findings are exactly these
rules, and the generated README lists them with their reasons. CasADi's model code and OSQP are not ours and are
not held to it.
"""

from __future__ import annotations

MISRA_DEVIATIONS = (
    (
        "2.3",
        "advisory",
        "Unused type declarations: the compile-time checks (`typedef char check_..[cond ? 1 : -1]`, "
        "C99 has no `_Static_assert`) fail the build when the real type or a CasADi work size does not match.",
    ),
    (
        "2.4",
        "advisory",
        "Unused tag declarations: anonymous enums name the API's integer constants (exit codes, "
        "QP statuses) and the stage kinds; they declare no type.",
    ),
    (
        "2.5",
        "advisory",
        "Unused macros: the header's size macros are for the caller (buffer sizes); the file "
        "itself uses some of them only.",
    ),
    (
        "8.9",
        "advisory",
        "Objects used by one function defined at file scope: the generated tables (QP layout, "
        "bounds, stage descriptors, the backend's data) stay together at the top of the file, next to the layout "
        "they describe, instead of being spread over the functions.",
    ),
    (
        "15.5",
        "advisory",
        "Several return statements: argument and state checks return their error code at once, "
        "as the exit codes document; a single exit would nest every function's body.",
    ),
    (
        "20.1",
        "advisory",
        "`#include` after code: the QP backend (`templates/backends/`) is one block included "
        "after the core's tables and types, which it uses; its own headers come with it.",
    ),
)
"""(rule, category, reason) of every MISRA C:2012 rule the emitted solver deviates from."""


def deviated_rules() -> set[str]:
    return {rule for rule, _, _ in MISRA_DEVIATIONS}
