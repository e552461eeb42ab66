"""The coupling polynomial joint = c0 + c1 q + c2 q^2 + ...: value, exact range, least-squares line.

Its own module so that the spec, the exporters and the validator all use it without reaching sideways.
"""

from __future__ import annotations

import numpy as np


def polyval(coeffs: tuple[float, ...], q: np.ndarray | float) -> np.ndarray | float:
    return sum(c * np.power(q, i) for i, c in enumerate(coeffs))


def image(coeffs: tuple[float, ...], lower: float, upper: float) -> tuple[float, float]:
    """Exact range of the polynomial over [lower, upper] (endpoints and interior extrema)."""
    points = [lower, upper]
    derivative = np.polynomial.polynomial.polyder(coeffs) if len(coeffs) > 1 else []
    if len(derivative) > 1:
        for root in np.polynomial.polynomial.polyroots(derivative):
            if abs(root.imag) < 1e-12 and lower < root.real < upper:
                points.append(float(root.real))
    values = [float(polyval(coeffs, p)) for p in points]
    return min(values), max(values)


def linearise(coeffs: tuple[float, ...], lower: float, upper: float) -> tuple[float, float]:
    """(offset, multiplier) of the least-squares line through the polynomial over the channel range."""
    if len(coeffs) <= 2:
        return coeffs[0], coeffs[1] if len(coeffs) > 1 else 0.0
    q = np.linspace(lower, upper, 201)
    multiplier, offset = np.polyfit(q, polyval(coeffs, q), 1)
    return float(offset), float(multiplier)
