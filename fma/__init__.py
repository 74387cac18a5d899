"""Fugl-Meyer analysis: measurements, features, datasets, classifiers and statistics (reads fusion types only)."""
