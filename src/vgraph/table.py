"""The Table port data type: named, typed columns of equal length, each with its unit, as
measurements (a line profile, statistics per region) hand them on.

Conventions:
- A table is a tuple of ``Column``s. A column holds a 1D numpy array (numbers, or strings for
  names), a name (snake_case, as ports and properties) and a unit ("" for none; lengths in the
  volume's world units are "world", areas "world^2", volumes "world^3": the spacing's units, mm
  for medical data).
- CSV (``to_csv``): a header row of the names, the unit in brackets where there is one
  ("distance [world]"), then one row per table row; numbers as Python's repr writes them (every
  float64 digit kept, so a read-back is exact), NaN as "nan". Written atomically (vgraph.atomic).
- ``lines()`` is the table as text for people (the GUI's inspector shows a measuring processor's
  table this way): the headings, then the rows with numbers to 6 significant digits, at most
  ``max_rows`` of them and a line saying how many more.
- ``to_numpy()`` is a numpy structured array with one field per column (what
  ``Network.evaluate`` returns for a table port): ``array["value"]``, ``array[0]``.
- A table is small (measurements, not voxels): it lives in memory and is copied freely.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass

import numpy as np

from vgraph.atomic import write_text_atomic
from vgraph.errors import VGraphError
from vgraph.ports import SNAKE_CASE


@dataclass(frozen=True, eq=False)
class Column:
    name: str
    values: np.ndarray
    unit: str = ""

    def __post_init__(self):
        if not SNAKE_CASE.match(self.name):
            raise VGraphError(f"table column {self.name!r}: names must be snake_case")
        values = np.asarray(self.values)
        if values.ndim != 1:
            raise VGraphError(f"table column {self.name!r}: expected one value per row, got shape {values.shape}")
        if values.dtype.kind not in "biufU":
            raise VGraphError(f"table column {self.name!r}: unsupported value type {values.dtype}")
        object.__setattr__(self, "values", values)

    @property
    def heading(self) -> str:
        """The CSV header cell: the name, with the unit in brackets where there is one."""
        return f"{self.name} [{self.unit}]" if self.unit else self.name


@dataclass(frozen=True, eq=False)
class Table:
    columns: tuple[Column, ...]
    source: str = ""  # what made it ("LineProfile 'profile'"), for messages

    def __post_init__(self):
        columns = tuple(self.columns)
        names = [c.name for c in columns]
        if len(set(names)) != len(names):
            raise VGraphError(f"table{self._from}: duplicate column names {names}")
        lengths = {len(c.values) for c in columns}
        if len(lengths) > 1:
            raise VGraphError(f"table{self._from}: columns of different lengths "
                              f"{ {c.name: len(c.values) for c in columns} }")
        object.__setattr__(self, "columns", columns)

    @property
    def _from(self) -> str:
        return f" from {self.source}" if self.source else ""

    @property
    def names(self) -> list[str]:
        return [c.name for c in self.columns]

    @property
    def row_count(self) -> int:
        return len(self.columns[0].values) if self.columns else 0

    def column(self, name: str) -> Column:
        for column in self.columns:
            if column.name == name:
                return column
        raise VGraphError(f"table{self._from} has no column {name!r} (its columns: {', '.join(self.names)})")

    def __getitem__(self, name: str) -> np.ndarray:
        """The values of column ``name``."""
        return self.column(name).values

    def rows(self) -> list[tuple]:
        """The rows as tuples of Python values, in column order."""
        return list(zip(*(c.values.tolist() for c in self.columns)))

    def to_numpy(self) -> np.ndarray:
        """A structured array, one field per column, one element per row."""
        array = np.empty(self.row_count, dtype=[(c.name, c.values.dtype) for c in self.columns])
        for column in self.columns:
            array[column.name] = column.values
        return array

    def lines(self, max_rows: int = 12) -> list[str]:
        """The headings and up to ``max_rows`` rows as aligned text (module docstring)."""
        cells = [[c.heading for c in self.columns]]
        cells += [[cell_text(value) for value in row] for row in self.rows()[:max_rows]]
        widths = [max(len(row[i]) for row in cells) for i in range(len(self.columns))]
        lines = ["  ".join(cell.rjust(width) for cell, width in zip(row, widths)).rstrip() for row in cells]
        if self.row_count > max_rows:
            lines.append(f"... {self.row_count - max_rows} more rows")
        return lines

    def take(self, rows, names=None) -> "Table":
        """The rows at indices ``rows`` (in that order) of the columns ``names`` (all by default)."""
        rows = np.asarray(rows, dtype=np.intp)
        chosen = self.columns if names is None else [self.column(name) for name in names]
        return Table(tuple(Column(c.name, c.values[rows], c.unit) for c in chosen), self.source)

    def csv_text(self, delimiter: str = ",") -> str:
        """The CSV file's text; with ``delimiter="\\t"`` what a spreadsheet takes from the clipboard."""
        buffer = io.StringIO()
        writer = csv.writer(buffer, delimiter=delimiter, lineterminator="\n")
        writer.writerow([c.heading for c in self.columns])
        writer.writerows(self.rows())
        return buffer.getvalue()

    def to_csv(self, path) -> None:
        """Write the table as CSV (module docstring), atomically."""
        write_text_atomic(path, self.csv_text())

    def __repr__(self) -> str:
        return f"<Table{self._from}: {self.row_count} rows x {', '.join(c.heading for c in self.columns)}>"


def cell_text(value) -> str:
    """A value for people: numbers to 6 significant digits."""
    return f"{value:.6g}" if isinstance(value, float) else str(value)
