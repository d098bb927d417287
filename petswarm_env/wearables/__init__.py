"""Wearables of seed 002: the smart belt (activity, rotation) and the smart watch (gestures)."""
