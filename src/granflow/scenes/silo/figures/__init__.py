"""Figures of the silo scene, after Rubio-Largo, Maza & Hidalgo (2016)."""
from .common import R_REFERENCE, REDUCED_RUNGS, MAPS_PER_ROW, LOG_RANGE  # noqa: F401
from .discharge import fig02_flow_rate, fig03_fields, fig04_phi_orifice, fig05_vz_orifice, fig05d_orifice_plane, fig06_contact_pressure  # noqa: F401
from .stress import fig07_kinetic_pressure_maps, fig08_kinetic_axis, fig09_kinetic_w, fig10_cumulative, fig11_partial, fig12_partial_over_phi, fig13_beverloo, SILO_FIGURES  # noqa: F401
