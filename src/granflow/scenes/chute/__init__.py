"""Scene "chute": steady granular flow down a rough inclined plane.

Silbert, Ertas, Grest, Halsey, Levine & Plimpton (2001), Phys. Rev. E 64, 051302.
Monodisperse spheres on a rough base of frozen particles, periodic in x (flow) and
y, free surface on top, gravity tilted by theta (LAMMPS ``fix gravity ... chute``).
The checks: the total stress ratio :math:`-\\sigma_{xz}/\\sigma_{zz} = \\tan\\theta` in
the bulk, :math:`\\sigma_{zz}` equal to the weight of the material above, the Bagnold
velocity profile :math:`u \\propto h^{3/2} - (h - z)^{3/2}`, and the regimes (arrested
below :math:`\\theta_{stop}(h)`, steady, accelerating).
"""
from .scene import ChuteScene

SCENE = ChuteScene()

__all__ = ["SCENE", "ChuteScene"]
