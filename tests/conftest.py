"""Shared fixtures: headless rendering for every test."""

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
