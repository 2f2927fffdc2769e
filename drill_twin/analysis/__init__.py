"""Post-processing of finished runs: stick-slip statistics, output units."""
