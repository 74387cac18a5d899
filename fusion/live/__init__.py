"""Live fusion: camera clients stream skeleton frames to a server that fuses them as they arrive, and
publishes the fused frames to subscribers and, optionally, as a Lab Streaming Layer stream
(``lsl_outlet``; ``pylsl``, the ``lsl`` extra, is imported only when an outlet opens). Imports io/,
calibrate/, merge/ and the data model of ``fusion``; nothing imports it but ``scenarios``."""
