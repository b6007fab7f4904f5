"""Polygonal wear: the tread's vibration written into the tire's profile.

The wear law (``law``), the linear wear map over speed and polygon order (``map``), the
nonlinear evolution of the worn profile over distance (``evolution``), the design
against wear (``design``) and the wear indicators of a steady vibration
(``indicators``). Stands on the dynamics; nothing here imports studies, measured data
or the report.
"""
