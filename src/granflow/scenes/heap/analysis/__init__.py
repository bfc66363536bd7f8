"""Analysis of the bounded heap (Fan et al. 2013): free surface, moving frame, flowing layer."""
from .surface import PHI_C, ALPHA_PLANAR_MIDDLE, EXPONENTIAL_DEPTH_FACTOR, EXPONENTIAL_FIT_MIN_FRACTION, LINEAR_RANGE, CUTOFF_FRACTION, K_EXPONENTIAL, TAIL_RANGE, MIN_LAYER_POINTS, DELTA_MEAN_RANGE, Q_STAR_MIN_X_OVER_L, SCALAR_KEYS, HeapGeometry, uniform_edges, sphere_slab_fraction, volume_fraction_columns, phi_columns_table, free_surface, bed_volume_fraction, surface_table, surface_grid, SurfaceFit, surface_fit_range, fit_surface, rise_inefficiency  # noqa: F401
from .kinematics import MovingFrame, KinematicsAccumulator, accumulate_frame, surface_velocity  # noqa: F401
from .layer import local_surface, shift_to_surface, ExponentialDepth, delta_exponential, delta_linear, delta_cutoff, delta_eq31, normal_velocity_linear, normal_velocity_exponential, TailFit, fit_exponential_tail, PowerLawFit, fit_power_law, mass_balance, analyse_heap, collapse, delta_over_local_d  # noqa: F401
from .deposit import deposit_concentration, deposit_contrast, deposit_variants, deposit_contrast_error, DEPOSIT_CENTRAL, DEPOSIT_SLABS  # noqa: F401
from .flux import species_flux_above  # noqa: F401
from .travel import fed_travel  # noqa: F401
from .phi import PHI_C_RANGE, BED_TOP, BED_TOP_VARIANTS, BED_THICKNESS, BED_CLEARANCE, BANDS, bed_columns, static_bed_table, static_bed_phi, tilt_free_spans, surface_cutoff_table, surface_cutoff_max, phi_profile_accumulator, base_height, phi_profile_table, band_falls, phi_above  # noqa: F401
from .gap import WALL_SLICE, CENTRE_SLICE, CS_SPLIT, slices, slice_share, GapKinematics, gap_surface_velocity, deposit_gap, gap_contrast  # noqa: F401
