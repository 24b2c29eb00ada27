"""What the main window shows and logs about rendering: each evaluation's new failures,
recoveries, warnings and empty images in the log (not every evaluation's: that would drown it) and
its summary in the status bar; "rendering..." while busy and, once a frame is overdue (the
watchdog, LiveEvaluation.stalled), a "Cancel rendering" button (and Network > Cancel Rendering)
that restarts the render process; Network > Render on Cluster... and its progress.
``RenderStatus`` is mixed into ``MainWindow`` (app.py); the running processor's progress bar is
progress_view.py.
"""

from __future__ import annotations

from PySide6.QtWidgets import QPushButton

from vgraph.gui.cluster_dialog import ClusterDialog, save_setting
from vgraph.live.evaluator import EvaluationOutcome, format_seconds


class RenderStatus:
    """Rendering reports and controls of a MainWindow (a mix-in before QMainWindow)."""

    def _add_cancel_button(self) -> None:
        """The status bar's "Cancel rendering", shown while a frame is overdue."""
        self.cancel_button = QPushButton("Cancel rendering")
        self.cancel_button.setToolTip("stop the render process and start a new one")
        self.cancel_button.clicked.connect(self.cancel_rendering)
        self.cancel_button.hide()
        self.statusBar().addPermanentWidget(self.cancel_button)

    def _busy_changed(self, busy: bool) -> None:
        self.cancel_action.setEnabled(busy)
        if busy:
            self.show_message("rendering...")
        else:
            self.cancel_button.hide()

    def _stalled(self, seconds: float) -> None:
        self.show_message(f"rendering for {seconds:.0f} s...")
        self.cancel_button.show()

    def edit_cluster(self) -> None:
        dialog = ClusterDialog(self.evaluation.cluster, self)
        if dialog.exec():
            self.set_cluster(dialog.setting())

    def set_cluster(self, setting, save: bool = True) -> None:
        """Render final frames on ``setting``'s cluster (None: here); stored with the preferences."""
        if save:
            save_setting(self.workspace.settings, setting)
            self.log.info(f"final frames render on cluster {setting.describe()}" if setting
                          else "final frames render here (no cluster)")
        self.evaluation.set_cluster(setting)

    def _cluster_progress(self, done: int, total: int) -> None:
        self.show_message(f"rendering on the cluster: {done}/{total} tiles")

    def cancel_rendering(self) -> None:
        if self.evaluation.cancel():
            self.show_message("rendering cancelled: the next change renders again")

    def report_outcome(self, outcome: EvaluationOutcome) -> None:
        """Log new failures and recoveries (not every evaluation: that would drown the log)."""
        self.scene.refresh_states()
        self.inspector.refresh_status()
        network = self.workspace.network
        for pid, reason in outcome.failed.items():
            if self.failures.get(pid) != reason and pid in network:
                self.log.error(f"processor '{pid}' ({network[pid].type_name}): {reason}")
        for pid in set(self.failures) - set(outcome.failed):
            if pid in outcome.ran:
                self.log.info(f"processor '{pid}' evaluates again")
        self.failures = {pid: r for pid, r in self.failures.items() if pid not in outcome.ran}
        self.failures.update(outcome.failed)
        for warning in outcome.warnings:
            self.log.warning(warning)
        for display, warning in outcome.blank.items():
            if self.blank_warnings.get(display) != warning:
                self.log.warning(warning)
        self.blank_warnings = dict(outcome.blank)
        failed = f", {len(outcome.failed)} failed" if outcome.failed else ""
        seconds = self.evaluation.last_result.seconds if self.evaluation.last_result else 0.0
        self.show_message(f"evaluated {len(outcome.ran)} processor{'s' * (len(outcome.ran) != 1)}"
                          f"{failed} in {format_seconds(seconds)}")
