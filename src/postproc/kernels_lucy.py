"""Lucy's kernel (Lucy 1977), the compactly supported radial kernel of :mod:`postproc.kernels_radial`
(:class:`~postproc.kernels_radial.RadialKernel` on every coordinate system); :mod:`postproc.kernels`
re-exports it."""
from __future__ import annotations

import numpy as np

from .kernels_radial import RadialKernel


class Lucy(RadialKernel):
    """Lucy's polynomial kernel (Lucy 1977), evaluated at the nodes of a grid.

    .. math::

        f(d) = (1 + 3s)(1 - s)^3 = 1 - 6s^2 + 8s^3 - 3s^4, \\qquad s = d / c < 1,

    zero beyond the cutoff :math:`c`, with continuous first and second
    derivatives there. Normalised in :math:`D` dimensions,
    :math:`Z_D = \\frac{2\\pi^{D/2}}{\\Gamma(D/2)} c^D \\int_0^1 f\\, s^{D-1}\\,\\mathrm ds`:

    .. math::

        \\frac{1}{Z_1} = \\frac{5}{4c}, \\qquad
        \\frac{1}{Z_2} = \\frac{5}{\\pi c^2}, \\qquad
        \\frac{1}{Z_3} = \\frac{105}{16\\pi c^3}.

    The geometries are those of :class:`RadialKernel` (Cartesian: the
    :math:`D`-dimensional kernel per unit transverse measure; ``rz``: the 3D
    kernel averaged over the azimuth; ``r``: the 2D kernel averaged over the
    azimuth per unit height), always by :func:`deposit_by_assignment`.

    Its :attr:`width` is the standard deviation of the 3D kernel along one axis,

    .. math::

        w^2 = \\tfrac13 \\langle d^2 \\rangle
            = \\frac{4\\pi c^5}{3 Z_3} \\int_0^1 f\\, s^4\\,\\mathrm ds
            = \\frac{4\\pi c^5}{3 Z_3}\\cdot\\frac{1}{105} = \\frac{c^2}{12},
        \\qquad w = \\frac{c}{2\\sqrt3} \\approx 0.289\\, c,

    comparable to a Gaussian of that standard deviation (the branch quadrature
    of the contact stress resolves :math:`w`).

    Parameters
    ----------
    cutoff : float
        Support radius :math:`c`, length units.
    nodes : array_like or sequence of array_like
        Grid axes, one increasing array per coordinate.
    """

    #: :math:`c^D / Z_D`, the normalisations in units of the cutoff.
    _UNIT_NORMALISATION = {1: 4.0 / 5.0, 2: np.pi / 5.0, 3: 16.0 * np.pi / 105.0}

    def __init__(self, cutoff: float, nodes):
        super().__init__(cutoff, nodes)
        self.width = self.cutoff / (2.0 * np.sqrt(3.0))

    def profile(self, d2) -> np.ndarray:
        """:math:`(1 + 3s)(1 - s)^3`, :math:`s = d/c`, zero for :math:`s \\ge 1`.

        Parameters
        ----------
        d2 : ndarray
            Squared distances, in the unit of the cutoff squared.

        Returns
        -------
        ndarray
            Dimensionless, the shape of ``d2``.
        """
        s = np.minimum(np.sqrt(d2) / self.cutoff, 1.0)
        return (1.0 + 3.0 * s) * (1.0 - s) ** 3

    def normalisation_in(self, dim: int) -> float:
        """:math:`Z_D`: :math:`4c/5`, :math:`\\pi c^2/5`, :math:`16\\pi c^3/105` for D = 1, 2, 3.

        Parameters
        ----------
        dim : int
            D: 1, 2 or 3.

        Returns
        -------
        float
            In the unit of the cutoff to the power D.

        Raises
        ------
        ValueError
            For another ``dim``.
        """
        if dim not in self._UNIT_NORMALISATION:
            raise ValueError(f"dimension must be 1, 2 or 3, not {dim}")
        return self._UNIT_NORMALISATION[dim] * self.cutoff**dim
