"""Analysis of the silo discharge (Rubio-Largo et al. 2016): rates, steady window, Beverloo, profiles."""
from .discharge import SQRT_PROFILE_RANGE, PHI_MIN_PARTIAL, linear_fit, cumulative_rate, species_ids, field_map, flow_rates, steady_window, steady_flow_rate, beverloo_law, beverloo_linearised, beverloo_fit  # noqa: F401
from .profiles import orifice_profiles, axis_profile, transition_height, cumulative_kinetic_pressure, partial_over_fraction, scaled_flow_rate, velocity_scaling_fit, mean_diameter  # noqa: F401
