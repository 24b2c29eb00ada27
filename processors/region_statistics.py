"""RegionStatistics: per label (or per mask) of a label volume, its voxel count, volume, surface
area and the statistics of an intensity volume's values inside it, as a table: 3D Slicer's Segment
Statistics.

Conventions (vgraph.measure_regions holds the rules; docs/guide/measuring.md shows them):
- ``labels``: a volume of whole numbers, 0 the background. ``regions = labels``: one row per label
  value present, ascending; ``mask``: one row (label 1) for all non-zero voxels.
- ``volume`` (optional): the intensities, on the same grid as the labels (same voxel counts and
  affine, else a named error). Without it the table has no value columns.
- ``label_table`` (link it to a LabelRayCaster's): with ``regions = labels``, a ``name`` column
  beside ``label`` holds each region's name from it ("" for an unnamed one), when it names one of
  the regions present (the default table names only the background, 0: no column).
- Columns: label, (name,) count, volume (world units cubed), then with intensities mean, std (population),
  min, max and one ``p<percent>`` per entry of ``percentiles`` (p2_5 for 2.5), then surface_area
  (world units squared, marching cubes) when ``surface_area`` is on.
- ``vgraph run --port stats.table --data stats.csv`` writes the table as CSV.
- Refused by name: labels that are not whole numbers, labels all 0 ("no labels present"), an
  intensity volume on another grid, percentiles that are not numbers in [0, 100] or repeat.
"""

from __future__ import annotations

from vgraph import (BoolProperty, Inport, LabelTableProperty, OptionProperty, Outport, Processor, PropertyError,
                    StringProperty)
from vgraph.labels import LabelTable
from vgraph.measure_regions import (REGION_RULES, check_same_grid, percentile_name, region_codes, region_table,
                                    with_names)
from vgraph.table import Table
from vgraph.volume import Volume
from vgraph.volume_filtering import samples_in_memory


class RegionStatistics(Processor):
    """Count, volume, surface area and value statistics per label of a label volume, as a table."""

    category = "Measuring"
    inports = [Inport("labels", Volume, description="label values, 0 the background"),
               Inport("volume", Volume, optional=True, description="intensities on the labels' grid")]
    outports = [Outport("table", Table, description="one row per region")]

    regions = OptionProperty("labels", choices=list(REGION_RULES),
                             doc="labels: one region per label value; mask: all non-zero voxels as one")
    percentiles = StringProperty("5, 25, 50, 75, 95",
                                 doc="percentiles of the values per region, in [0, 100], comma-separated (may be empty)")
    surface_area = BoolProperty(True, doc="the area of each region's boundary (marching cubes)")
    label_table = LabelTableProperty(LabelTable.default(),
                                     doc="the labels' names, for a name column (link it to a LabelRayCaster's)")

    def check(self) -> None:
        self.percent_values()

    def percent_values(self) -> list[float]:
        """The ``percentiles`` property as numbers; PropertyError naming it otherwise."""
        where = f"{self.id}.percentiles"
        try:
            percents = [float(p) for p in self.percentiles.replace(",", " ").split()]
        except ValueError:
            raise PropertyError(where, f"expected numbers in [0, 100] separated by commas, got "
                                f"{self.percentiles!r}") from None
        bad = [p for p in percents if not 0.0 <= p <= 100.0]
        if bad:
            raise PropertyError(where, f"percentiles must lie in [0, 100], got {bad[0]:g}")
        names = [percentile_name(p) for p in percents]
        if len(set(names)) != len(names):
            raise PropertyError(where, f"a percentile is given twice: {self.percentiles!r}")
        return percents

    def __init__(self, id=None, **values):
        super().__init__(id, **values)
        self.table: Table | None = None  # the last run's, for the inspector
        self._measured: tuple | None = None  # (inputs and settings, the table without names)

    def frame_summary(self) -> str:
        """The table's rows, for the GUI's inspector (the first 12; the CSV holds all)."""
        return "\n".join(self.table.lines()) if self.table is not None else ""

    def process(self, labels: Volume, volume: Volume | None = None) -> Table:
        self.table = None
        who = f"RegionStatistics '{self.id}'"
        percents = self.percent_values()
        for each in (labels, volume):
            if each is not None:
                samples_in_memory(each, who)
        self.table = self._statistics(labels, volume, percents, who)
        if self.regions == "labels":
            self.table = with_names(self.table, {e.value: e.name for e in self.label_table.labels if e.name})
        return self.table

    def _statistics(self, labels: Volume, volume: Volume | None, percents: list[float], who: str) -> Table:
        """The table without names, kept while the inputs and settings stay: a colour or a name
        changed in a linked label table must not measure every region again."""
        settings = (tuple(percents), self.regions, self.surface_area)
        kept = self._measured
        if kept is not None and kept[0] is labels and kept[1] is volume and kept[2] == settings:
            return kept[3]
        codes = region_codes(labels, self.regions, who)
        if volume is not None:
            check_same_grid(labels, volume, who)
        table = region_table(codes, labels, volume, percents, self.surface_area, who)
        self._measured = (labels, volume, settings, table)
        return table
