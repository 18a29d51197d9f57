"""Synthetic reconstructed flight data with known coefficient functions (fast tests)."""

from __future__ import annotations

import numpy as np
import pandas as pd

COEFS = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")


def true_cz(alpha, de, mach, qhat):
    """A smooth nonlinear CZ: cubic in alpha, linear in de, a Mach term and a pitch-damping
    term that only shows when qhat is in the model."""
    return (-0.1 - 4.5 * alpha + 6.0 * alpha**3 - 0.6 * de + 2.0 * (mach - 0.5) ** 2
            - 30.0 * qhat)


def true_cm(alpha, de, qhat):
    return 0.02 - 0.5 * alpha - 1.2 * de - 8.0 * qhat + 2.0 * alpha**2


def smooth_wave(rng: np.random.Generator, t: np.ndarray, amp: float, centre: float = 0.0, *,
                sines: int = 3, freq: tuple = (0.1, 1.0)) -> np.ndarray:
    """One maneuver's smooth random trajectory, shape (len(t),): ``centre`` plus ``amp``
    times the mean of ``sines`` sines of random frequencies in ``freq`` [Hz] and phases
    (drawn from ``rng`` in that order)."""
    f = rng.uniform(freq[0], freq[1], sines)
    ph = rng.uniform(0, 2 * np.pi, sines)
    return centre + amp * np.sum(np.sin(2 * np.pi * f[:, None] * t + ph[:, None]),
                                 axis=0) / sines


def synthetic_table(n_maneuvers: int = 12, samples: int = 800, *, seed: int = 0,
                    noise: float = 2e-3) -> pd.DataFrame:
    """Reconstructed-style flight data: each maneuver a smooth random trajectory.

    Columns: maneuver, t, maneuver_type, alpha, beta, mach, tas, de, da, dr, phat, qhat,
    rhat, CX..Cn (measured = truth + white noise) and true_CX..true_Cn.
    """
    rng = np.random.default_rng(seed)
    parts = []
    t = np.arange(samples) * 0.01
    for m in range(n_maneuvers):
        def wave(amp, centre=0.0):
            return smooth_wave(rng, t, amp, centre)

        alpha = wave(0.12, rng.uniform(0.02, 0.2))
        de = wave(0.08)
        mach = np.clip(wave(0.05, rng.uniform(0.35, 0.75)), 0.3, 0.8)
        qhat = wave(0.004)
        beta, da, dr = wave(0.05), wave(0.1), wave(0.1)
        phat, rhat = wave(0.02), wave(0.01)
        truth = {
            "CX": -0.03 + 0.4 * alpha**2 + 0.05 * de * alpha,
            "CY": -0.9 * beta + 0.15 * dr + 0.02 * da,
            "CZ": true_cz(alpha, de, mach, qhat),
            "Cl": -0.08 * beta - 0.1 * da - 0.3 * phat + 0.05 * rhat,
            "Cm": true_cm(alpha, de, qhat),
            "Cn": 0.1 * beta - 0.06 * dr - 0.2 * rhat,
        }
        kind = ("3211-elevator", "doublet-elevator", "sum-of-sines")[m % 3]
        frame = {"maneuver": np.full(samples, m), "t": t, "maneuver_type": kind,
                 "alpha": alpha, "beta": beta, "mach": mach, "tas": mach * 320.0,
                 "de": de, "da": da, "dr": dr, "phat": phat, "qhat": qhat, "rhat": rhat}
        for c in COEFS:
            frame[f"true_{c}"] = truth[c]
            frame[c] = truth[c] + noise * rng.standard_normal(samples)
        parts.append(pd.DataFrame(frame))
    df = pd.concat(parts, ignore_index=True)
    df.attrs = {"aircraft": "synthetic", "S": 20.0, "b": 10.0, "cbar": 2.0}
    return df
