#!/usr/bin/python3
"""Timoshenko beam frequencies of the example rod of docs/validation_references.md, the continuum
limit of the CoRdE rod (shear stiffness kappa = G A, rotary inertia rho I), against
Euler-Bernoulli.

Independent of the C++ code (scipy shooting + brentq); its ratios are the reference constants in
test/validation/frequency_test.cpp and test/validation/accuracy_test.cpp. Run: scripts/timoshenko_frequencies.py
"""
import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

E, G, R, RHO, L = 1e7, 1e7 / 3, 0.01, 1000.0, 1.0
A, I = np.pi * R**2, np.pi * R**4 / 4
B, KAPPA, MU, RHO_I = E * I, G * A, RHO * A, RHO * I


def rhs(_x, y, w2):
    # State (w, psi, M, V): w' = psi + V/kappa, psi' = M/B, M' = -V - rho I w2 psi,
    # V' = -mu w2 w.
    w, psi, m, v = y
    return [psi + v / KAPPA, m / B, -v - RHO_I * w2 * psi, -MU * w2 * w]


def determinant(omega, ends):
    """Zero at a natural frequency: free end (M = V = 0) at x = L."""
    starts = [[1, 0, 0, 0], [0, 1, 0, 0]] if ends == "free-free" else [[0, 0, 1, 0], [0, 0, 0, 1]]
    tips = [solve_ivp(rhs, [0, L], y0, args=(omega**2,), rtol=1e-12, atol=1e-14).y[:, -1]
            for y0 in starts]
    return tips[0][2] * tips[1][3] - tips[0][3] * tips[1][2]


def main():
    scale = np.sqrt(B / (MU * L**4))
    cases = {"free-free": [4.730041, 7.853205, 10.995608],
             "clamped-free": [1.875104, 4.694091, 7.854757, 10.995541]}
    for ends, betas in cases.items():
        for n, beta in enumerate(betas, 1):
            eb = beta**2 * scale
            timo = brentq(determinant, 0.97 * eb, 1.001 * eb, args=(ends,), xtol=1e-14)
            print(f"{ends:12s} mode {n}: EB {eb:.6f} rad/s, Timoshenko {timo:.6f} rad/s, "
                  f"ratio - 1 = {timo / eb - 1:+.4e}")


if __name__ == "__main__":
    main()
