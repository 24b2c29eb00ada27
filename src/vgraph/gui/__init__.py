"""The vgraph GUI (PySide6): a network editor, a property inspector, a processor palette and a log,
all views of one ``vgraph.Network``.

Conventions:
- The network is the model and never imports Qt. The GUI subscribes to its events
  (``Network.subscribe``) and redraws; every edit is a record of ``vgraph.edits`` that calls
  Network methods, pushed in a QUndoCommand (``commands.py``), so undo/redo covers every edit.
- The GUI process holds no OpenGL context: a render process (``vgraph.live``, which imports no
  Qt) owns the EGL context and a mirror of the network, evaluates, and sends frames back as images.
- Importing ``vgraph.gui`` imports no Qt; the modules below do (``vgraph gui`` imports them lazily).

Modules: app (main window; its menus in menus, its rendering reports in render_status), workspace (file, undo stack, edit operations), commands,
scene and items (the node editor), interactions (drag-to-connect), palette, editors and inspector
(property widgets), transfer_function_editor, canvas_view, canvas_mouse and canvases (the rendered
images and the trackball), links (link dialog, auto-linked cameras), log (log panel),
live_evaluation (what runs, where, and when, through the render process of ``vgraph.live``; its
watchdog in render_watchdog).
"""
