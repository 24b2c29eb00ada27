"""The vgraph GUI (PySide6): a network editor, a property inspector, a processor palette and a log,
all views of one ``vgraph.Network``.

Conventions:
- The network is the model and never imports Qt. The GUI subscribes to its events
  (``Network.subscribe``) and redraws; every edit goes through a QUndoCommand (``commands.py``)
  that calls Network methods, so undo/redo covers every edit.
- The GUI process holds no OpenGL context. ``evaluator.Evaluator`` is the one place that evaluates:
  for now it runs in-process only the processors that need no GL; the render process plugs in there.
- Importing ``vgraph.gui`` imports no Qt; the modules below do (``vgraph gui`` imports them lazily).

Modules: app (main window, menus), workspace (file, undo stack, edit operations), commands,
scene and items (the node editor), interactions (drag-to-connect), palette, editors and inspector
(property widgets), links (link dialog, auto-linked cameras), log (log panel), evaluator and
live_evaluation (what runs, and when).
"""
