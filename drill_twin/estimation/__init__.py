"""Downhole estimation from surface data (no ROS): what the bit does, seen from the rig."""
