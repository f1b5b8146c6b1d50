"""What maps are read from and written to: the map file, the compact map, GeoJSON, ROS map_server,
SVG and the exports built on them; `files` writes atomically."""
