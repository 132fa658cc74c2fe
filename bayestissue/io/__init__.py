"""File input and output: the only layer of the library that reads or writes files."""

from bayestissue.io.tables import read_table, write_table

__all__ = ["read_table", "write_table"]
