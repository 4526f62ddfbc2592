"""``fcgen fmu``: a generated solver folder packaged as a co-simulation FMU (FMI 3.0 or 2.0; ``package``), and a
closed-loop controller that drives such an FMU through FMPy (``controller``).

The FMU holds ``modelDescription.xml``, the sources (the solver folder's C and the wrapper fcgen renders from
``templates/fmu/``: one core, two thin FMI layers), a binary for this platform built from them, and the folder's
README under ``documentation/``. The FMI headers come from the installed ``fmpy`` package (the ``fmu`` extra).
"""

from .controller import FmuController, fmu_problem
from .package import (
    FMI_VERSIONS,
    PLATFORM,
    FmuError,
    Var,
    build_description,
    build_fmu,
    fmi2_bases,
    fmi_headers,
    model_description,
    variables,
    wrapper_sources,
)

__all__ = [
    "FMI_VERSIONS",
    "PLATFORM",
    "FmuController",
    "FmuError",
    "Var",
    "build_description",
    "build_fmu",
    "fmi2_bases",
    "fmi_headers",
    "fmu_problem",
    "model_description",
    "variables",
    "wrapper_sources",
]
