"""Stage io: readers of real formats (:mod:`fusion.io.formats`), the recording and calibration file
formats, motion-capture files, exports to other tools, and safe (atomic) file writing.

May import the data model at the top of :mod:`fusion`; no other stage.
"""
