"""Calibration of fixed multi-camera rigs: spheres (rank-1 constraint), 1-D
objects from two spheres, structured light with a sphere, and the fundamental
matrix from six points with four coplanar. Imports ``geometry`` only.

Use it as a library: ``from calib import sphere``.
"""
