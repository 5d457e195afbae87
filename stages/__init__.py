"""Thin typer commands, one module per pipeline stage; all logic lives in ``hevlib``."""
