"""Timing loops for ``uuvid bench``; each prints its ratio against a plain reference run."""
