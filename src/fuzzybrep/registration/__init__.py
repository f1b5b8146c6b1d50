"""Registration: where scans lie, from their odometry and from each other."""
