"""``mocap-bench sensor-check``: measure the simulated sensors against the facts they model.

Six sections, each a table of checks (measured value, expected value, accepted interval, pass):

1. render-then-measure: spheres seen by an ideal depth camera land where the intrinsics say;
2. depth noise: walls at several distances and tilts, residual std against Fankhauser's sigma;
3. back-facing: the skeleton's left/right labels swap when the subject turns its back;
4. occlusion: a hand behind the back is Inferred from the front and Tracked from behind;
5. bone lengths: rigid in the truth; their spread in a single simulated Kinect against the range
   the sensor facts imply;
6. clocks: frame rate, dropped frames, timestamp jitter and offsets of the camera clocks.

Everything is drawn from one seed (split with ``SeedSequence.spawn`` per section). Expected values
come from ``reference/sensors.md`` (through the sensor models' defaults) or from closed forms.
"""
