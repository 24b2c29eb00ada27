"""Live evaluation of a network being edited: the render process, its server and messages, the
evaluator, the changes it applies. Nothing here imports Qt; the GUI's views (vgraph.gui) use this
package, never the other way round.

Modules: render_process (starts the child, sends jobs, reads results), render_messages (what the
two sides send each other), render_server (the child's loop: mirror the network, apply the edits,
evaluate), evaluator (one view's frame, processor status, histograms), changes (edits sent to the
child), mirror (a document applied as a diff), progress_messages, view_boxes, cluster (a view
rendered on the cluster's workers), slice_clicks and upstream (which processor a click in a canvas
lands on).
"""
