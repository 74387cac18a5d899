"""Live fusion: camera clients stream skeleton frames to a server that fuses them as they arrive."""
