"""The dynamics of the paper: does the tread vibrate, at which speeds, how strongly.

Stability of steady rolling (Hopf points), the bifurcation diagram by continuation
(first and second bifurcation speeds, the SEV band), time simulation and attractors,
soft and hard excitation, sweeps, stability maps in two parameters, local sensitivity
of the bifurcation speeds, and the design search that moves the band out of a speed
range. Imports models, solvers, friction and the base layers, nothing above.
"""
