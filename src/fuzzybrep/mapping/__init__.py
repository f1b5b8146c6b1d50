"""Steps (a)-(g) of thesis 3.2: evidence from all scans, lines (Hough, IEPF), scan polygons, their
union into the crisp B-rep map, and `build_map` that runs them; also the occupancy-grid mapper the
thesis compares with (`grid`)."""
