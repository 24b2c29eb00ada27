"""The tables the render process sends the window (vgraph.live.tables): each once, when its
processor ran again; every address each time, so the window drops what is gone."""

import numpy as np

from vgraph import Network
from vgraph.live.tables import TableSender, merged_tables, table_outputs
from vgraph.testing import GivenVolume
from vgraph.volume import Volume


def measured() -> Network:
    labels = np.zeros((3, 4, 5), np.uint8)
    labels[0, :2] = 1
    labels[2, 3, 1:] = 2
    network = Network()
    network.add(GivenVolume(id="src", volume=Volume(labels, spacing=(1.0, 1.0, 1.0))))
    network.add("RegionStatistics", id="stats", surface_area=False)
    network.connect("src.volume", "stats.labels")
    network.update("stats.table")
    return network


def test_a_table_is_sent_once_until_its_processor_runs_again():
    network, sender = measured(), TableSender()
    new, addresses = sender.changes(network)
    assert addresses == ("stats.table",) and list(new["stats.table"]["count"]) == [10, 4]
    assert sender.changes(network) == ({}, ("stats.table",))   # nothing new: nothing sent
    network.set("stats.regions", "mask")
    assert table_outputs(network) == {}                        # invalidated: not up to date
    network.update("stats.table")
    new, _ = sender.changes(network)
    assert list(new["stats.table"]["count"]) == [14]
    sender.forget()                                            # the window starts over: sent again
    assert list(sender.changes(network)[0]) == ["stats.table"]


def test_the_window_keeps_what_was_sent_and_drops_what_is_gone():
    network = measured()
    table = network.output("stats.table")
    held = merged_tables({}, {"stats.table": table}, ("stats.table",))
    assert merged_tables(held, {}, ("stats.table",))["stats.table"] is table
    assert merged_tables(held, {}, ()) == {}


def test_take_and_tab_separated_text():
    table = measured().output("stats.table")
    assert table.take([1, 0], ["label", "count"]).csv_text("\t") == "label\tcount\n2\t4\n1\t10\n"
