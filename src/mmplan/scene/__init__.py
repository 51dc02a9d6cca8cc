"""Obstacles and scenes (written by the scene module owner)."""
