"""The nodes' real-time policy as plain classes (no ROS): pacing, health, arbitration,
the stability-advisory worker, the parameter tables."""
