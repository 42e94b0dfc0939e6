"""Plots a person checks."""
