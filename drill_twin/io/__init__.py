"""Recording and replay I/O (MCAP, rosbag2 profile); no ROS runtime needed."""
