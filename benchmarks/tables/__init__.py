"""The renderers of make_table.py, one module per kind of result file."""
