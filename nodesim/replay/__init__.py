"""Replaying recorded lab logs through the firmware model (log format, reader, replayer, comparison, recorder)."""
