"""Analysis paths without time integration: averaged effective friction and stability
(Secs. 5-6) and harmonic balance for the contact model (Sec. 3, Appendix A)."""
from .block import POINT_AXES, analysis_block
from .chart import stability_chart
from .effective import MODELS, effective_friction, negative_slope_zones, sine_force_simplified
from .hbm import HBMResult, contact_hbm
from .quadrature import N_QUAD, RULES, gauss_legendre, phase_average
from .stability import (
    averaged_rhs,
    averages,
    equilibrium,
    jacobian,
    jacobian_max_real_eig,
    linearisation,
    max_real_eig,
    static_max_real_eig,
)

__all__ = [
    "MODELS", "N_QUAD", "POINT_AXES", "RULES",
    "HBMResult", "analysis_block", "averaged_rhs", "averages", "contact_hbm",
    "effective_friction", "equilibrium", "gauss_legendre", "jacobian", "jacobian_max_real_eig",
    "linearisation", "max_real_eig",
    "negative_slope_zones", "phase_average", "sine_force_simplified", "stability_chart",
    "static_max_real_eig",
]
