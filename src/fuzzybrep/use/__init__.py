"""What the map is for: planning in α-cuts (`plan`, `visibility`, `medial`) and judging a map
against held-out scans (`evaluate`)."""
