// The ImGui panels of fabrica-viewer (docs/viewer.md): menu bar, structures,
// HUD, loading progress, errors, file dialogs; and the keyboard shortcuts.
#pragma once

namespace fabrica::viewer {

class Viewer;

/// Draws every panel for this frame and applies what the user changed.
void draw_ui(Viewer& viewer);

}  // namespace fabrica::viewer
