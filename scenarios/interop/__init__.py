"""Real-sensor files and recorded motion at the command line: ``import``, ``write``, ``roundtrip``
and the retargeting report of several motion sources; ``view``, the Rerun 3D viewer of runs,
recordings, fused outputs and plans (``rerun_view``; the room, rig, skeletons and plans it draws:
``rerun_plan``; needs the optional extra ``view``).

May import the core of :mod:`scenarios` and ``fusion``, ``sim``; no other workflow, no CLI.
"""
