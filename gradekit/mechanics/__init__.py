"""Planar mechanism kinematics and static/dynamic force analysis (numpy only)."""
