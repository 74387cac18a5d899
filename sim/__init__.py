"""Simulation: humanoid, motions, camera rig, virtual depth cameras and body trackers.

Every simulator returns ``(observation, truth)``; truth never travels inside an observation.
"""
