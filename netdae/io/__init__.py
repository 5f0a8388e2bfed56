"""Result files: ngspice raw (binary and ascii), CSV, and matrix export."""

from .csv import read_csv, write_csv
from .raw import read_raw, write_raw

__all__ = ["read_raw", "write_raw", "read_csv", "write_csv"]
