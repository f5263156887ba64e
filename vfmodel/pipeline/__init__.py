"""Pipelines composing the layers: summary, reproduce, diagnose, predict."""
