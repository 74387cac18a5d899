"""Orchestration: scenario files, runner, ground-truth evaluation, reports and the command line."""
