"""Analysis of the channel profiles (Debnath, Kesava Rao & Kumaran 2022): folding, velocity
scales and eq. 3.1, stress checks, rheology, flow zones and the scalars of the table."""
from .profile import PHI_AD, PHI_PLUG, WALL_LAYER, EXPONENT_EQ31, COORDINATE_COLUMNS, MuIParameters, JOP2015, downward_speed, mirror_parity, fold_profile, VelocityScales, scaled_velocity, velocity_scales, UniversalFit, universal_profile, fit_universal_profile, mean_velocity_eq32, StressChecks, stress_checks  # noqa: F401
from .rheology import rheology, FlowZones, flow_zones  # noqa: F401
from .scalars import ChannelAnalysis, analyse_profile, plug_phi, SCALAR_KEYS, scalars_from_analysis, analyse_channel  # noqa: F401
