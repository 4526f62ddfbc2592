"""Which problem names can prefix a C solver's symbols without clashing (C keywords, the C library, OSQP, CasADi).

The generated folder defines ``<name>_*`` identifiers (API, workspace, CasADi functions, OSQP's workspace with prefix
``<name>_``: ``<name>_solver``, ``<name>_info``, ...), ``<NAME>_*`` macros and CasADi's ``<name>__*`` internals, in
translation units that include OSQP's headers, CasADi's runtime and the C library. A name is refused when its
first ``_``-separated word opens a namespace one of those already uses, because then one suffix decides whether a
symbol clashes: ``update`` is OSQP's (``update_info`` is both OSQP's function and the workspace's ``OSQPInfo``),
``osqp``/``qdldl`` break the build outright, ``casadi`` collides with CasADi's own ``casadi_*`` helpers.

The sets were derived, not guessed (``tests/test_cnames.py`` derives them again and checks they are covered):
OSQP's from ``nm -g`` of ``lib<name>_osqp.a`` plus the macros, typedefs and enum constants of ``osqp/lib``'s headers
(osqp 1.1.3); the C library's from ``cc -std=c99`` on every C99 header (``-aux-info`` for function names, ``-E -dM``
for macros, the preprocessed text for ``*_t`` types).
"""

from __future__ import annotations

import re

C99_KEYWORDS = frozenset(
    "auto break case char const continue default do double else enum extern float for goto if inline int long "
    "register restrict return short signed sizeof static struct switch typedef union unsigned void volatile while "
    "bool true false complex imaginary".split()
)
"""C99 keywords, plus the lower-case spellings of ``_Bool``/``_Complex``/``_Imaginary`` that stdbool/complex.h
define."""

_MATH = (
    "acos acosh asin asinh atan atan2 atanh cbrt ceil copysign cos cosh erf erfc exp exp2 expm1 fabs fdim floor "
    "fma fmax fmin fmod frexp hypot ilogb ldexp lgamma llrint llround log log10 log1p log2 logb lrint lround "
    "modf nan nearbyint nextafter nexttoward pow remainder remquo rint round scalbln scalbn sin sinh sqrt tan "
    "tanh tgamma trunc"
).split()
_COMPLEX = (
    "cabs cacos cacosh carg casin casinh catan catanh ccos ccosh cexp cimag clog conj cpow cproj creal csin "
    "csinh csqrt ctan ctanh"
).split()
_OTHER = (
    "abort abs asctime atexit atof atoi atol atoll bsearch btowc calloc clearerr clock ctime difftime div exit "
    "fclose feclearexcept fegetenv fegetexceptflag fegetround feholdexcept feof feraiseexcept ferror fesetenv "
    "fesetexceptflag fesetround fetestexcept feupdateenv fflush fgetc fgetpos fgets fgetwc fgetws fopen fprintf "
    "fputc fputs fputwc fputws fread free freopen fscanf fseek fsetpos ftell fwide fwprintf fwrite fwscanf getc "
    "getchar getenv gets getwc getwchar gmtime imaxabs imaxdiv labs ldiv llabs lldiv localeconv localtime longjmp "
    "malloc mblen mbrlen mbrtowc mbsinit mbsrtowcs mbstowcs mbtowc mktime perror printf putc putchar puts putwc "
    "putwchar qsort raise rand realloc remove rename rewind scanf setbuf setjmp setlocale setvbuf signal snprintf "
    "sprintf srand sscanf swprintf swscanf system time tmpfile tmpnam ungetc ungetwc vfprintf vfscanf vfwprintf "
    "vfwscanf vprintf vscanf vsnprintf vsprintf vsscanf vswprintf vswscanf vwprintf vwscanf wcrtomb wcstombs wctob "
    "wctomb wctrans wctype wmemchr wmemcmp wmemcpy wmemmove wmemset wprintf wscanf "
    # lower-case macros
    "assert errno offsetof stderr stdin stdout fpclassify isfinite isinf isnan isnormal signbit isgreater "
    "isgreaterequal isless islessequal islessgreater isunordered and or not xor bitand bitor compl "
    "main"
).split()
C_LIBRARY = frozenset(_OTHER + _COMPLEX + [f + s for f in _MATH + _COMPLEX for s in ("", "f", "l")])
"""Identifiers of the C99 library (functions, lower-case macros) and ``main``: a solver may not be named like one."""

C_RESERVED_START = re.compile(r"^(str|mem|wcs|is|to)[a-z]")
"""C99 7.26: external names that begin with str/mem/wcs/is/to and a lower-case letter are reserved (our API is
``<name>_...`` with external linkage, so the name may not begin so)."""

# first word of an identifier -> one identifier of that namespace (for the message)
OSQP_NAMESPACES = {
    "osqp": "osqp_solve",
    "OSQP": "OSQP_NULL",
    "qdldl": "qdldl_solver",
    "QDLDL": "QDLDL_factor",
    "csc": "csc_Axpy",
    "CSC": "CSC_MATH_H",
    "c": "c_absval",
    "adapt": "adapt_rho",
    "check": "check_termination",
    "compute": "compute_rho_estimate",
    "has": "has_solution",
    "is": "is_dual_infeasible",
    "limit": "limit_scaling_scalar",
    "name": "name_qdldl",
    "reset": "reset_info",
    "scale": "scale_data",
    "set": "set_rho_vec",
    "solve": "solve_linsys_qdldl",
    "store": "store_solution",
    "swap": "swap_vectors",
    "unscale": "unscale_data",
    "update": "update_info",
    "validate": "validate_settings",
    "vec": "vec_mult_scalar",
    "warm": "warm_start_linsys_solver_qdldl",
    "ALGEBRA": "ALGEBRA_IMPL_H",
    "AUXIL": "AUXIL_H",
    "ERROR": "ERROR_H",
    "GLOB": "GLOB_OPTS_H",
    "KKT": "KKT_H",
    "LIN": "LIN_ALG_H",
    "PRINTING": "PRINTING_H_",
    "PROFILERS": "PROFILERS_H_",
    "SCALING": "SCALING_H",
    "TIMING": "TIMING_H_",
    "TYPES": "TYPES_H",
    "UTIL": "UTIL_H",
}
CASADI_NAMESPACES = {"casadi": "casadi_real", "CASADI": "CASADI_PREFIX", "CODEGEN": "CODEGEN_PREFIX"}
C_LIBRARY_NAMESPACES = {
    # types (*_t) and lower-case macros
    "va": "va_list",
    "math": "math_errhandling",
    "size": "size_t",
    "time": "time_t",
    "clock": "clock_t",
    "div": "div_t",
    "ldiv": "ldiv_t",
    "lldiv": "lldiv_t",
    "imaxdiv": "imaxdiv_t",
    "fenv": "fenv_t",
    "fexcept": "fexcept_t",
    "fpos": "fpos_t",
    "mbstate": "mbstate_t",
    "ptrdiff": "ptrdiff_t",
    "sig": "sig_atomic_t",
    "wchar": "wchar_t",
    "wint": "wint_t",
    "wctrans": "wctrans_t",
    "wctype": "wctype_t",
    "int": "int_fast16_t",
    "uint": "uint_fast16_t",
    "intmax": "intmax_t",
    "uintmax": "uintmax_t",
    "intptr": "intptr_t",
    "uintptr": "uintptr_t",
    "int8": "int8_t",
    "int16": "int16_t",
    "int32": "int32_t",
    "int64": "int64_t",
    "uint8": "uint8_t",
    "uint16": "uint16_t",
    "uint32": "uint32_t",
    "uint64": "uint64_t",
    "float": "float_t",
    "double": "double_t",
    "and": "and_eq",
    "or": "or_eq",
    "not": "not_eq",
    "xor": "xor_eq",
    # upper-case macros
    "INT": "INT_MAX",
    "UINT": "UINT_MAX",
    "LC": "LC_ALL",
    "FLT": "FLT_MAX",
    "DBL": "DBL_MAX",
    "LDBL": "LDBL_MAX",
    "FE": "FE_INVALID",
    "FP": "FP_NAN",
    "SIG": "SIG_DFL",
    "SEEK": "SEEK_SET",
    "INTMAX": "INTMAX_MAX",
    "UINTMAX": "UINTMAX_MAX",
    "INTPTR": "INTPTR_MAX",
    "UINTPTR": "UINTPTR_MAX",
    "INT8": "INT8_MAX",
    "INT16": "INT16_MAX",
    "INT32": "INT32_MAX",
    "INT64": "INT64_MAX",
    "UINT8": "UINT8_MAX",
    "UINT16": "UINT16_MAX",
    "UINT32": "UINT32_MAX",
    "UINT64": "UINT64_MAX",
    "HUGE": "HUGE_VAL",
    "CHAR": "CHAR_BIT",
    "SCHAR": "SCHAR_MAX",
    "UCHAR": "UCHAR_MAX",
    "SHRT": "SHRT_MAX",
    "USHRT": "USHRT_MAX",
    "LONG": "LONG_MAX",
    "ULONG": "ULONG_MAX",
    "LLONG": "LLONG_MAX",
    "ULLONG": "ULLONG_MAX",
    "WCHAR": "WCHAR_MAX",
    "WINT": "WINT_MAX",
    "PTRDIFF": "PTRDIFF_MAX",
    "SIZE": "SIZE_MAX",
    "MB": "MB_CUR_MAX",
    "MATH": "MATH_ERRNO",
    "EXIT": "EXIT_SUCCESS",
    "RAND": "RAND_MAX",
    "TMP": "TMP_MAX",
    "L": "L_tmpnam",
    "FOPEN": "FOPEN_MAX",
    "FILENAME": "FILENAME_MAX",
    "DECIMAL": "DECIMAL_DIG",
    "CLOCKS": "CLOCKS_PER_SEC",
}
NAMESPACES = (("OSQP", OSQP_NAMESPACES), ("CasADi", CASADI_NAMESPACES), ("the C library", C_LIBRARY_NAMESPACES))


def name_clash(name: str) -> str | None:
    """Why ``name`` cannot prefix the solver's C symbols, or None if it can (``name`` already matches
    [a-z][a-z0-9_]*)."""
    if name in C99_KEYWORDS:
        return "a C keyword"
    if name in C_LIBRARY:
        return "a C standard library identifier"
    if name.endswith("_") or "__" in name:
        return "a name ending in '_' or holding '__' (CasADi's internals are <name>__...)"
    m = C_RESERVED_START.match(name)
    if m:
        return (
            f"reserved (C99 7.26: external names beginning with {m.group(1)!r} and a lower-case letter belong to "
            f"the C library, and the API is {name}_...)"
        )
    head = name.split("_")[0]
    for owner, spaces in NAMESPACES:
        for key in (head, head.upper()):
            if key in spaces:
                return f"in {owner}'s namespace: {spaces[key]} and the solver's {key}_... symbols share '{key}_'"
    return None
