"""Cross-checks of polywear's own analysis against independent reference codes.

``auto07p``: the bifurcation diagram of ``tread1dof`` computed by AUTO-07p (through the
``bifpy`` package, optional extra ``polywear[auto07p]``; see
``scripts/ensure-auto07p.sh``). Submodules are imported on demand.
"""
