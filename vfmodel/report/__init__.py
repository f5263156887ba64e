"""Figures (matplotlib, imported lazily, Agg backend) and HTML reports."""
