// The ImGui panels of fabrica-viewer (docs/viewer.md): menu bar, structures,
// HUD, loading progress, errors, file dialogs; and the keyboard shortcuts.
#pragma once

#include <string>

namespace fabrica::viewer {

class Viewer;

/// Draws every panel for this frame and applies what the user changed.
void draw_ui(Viewer& viewer);

/// Opens (or closes) a structure's row and its Lines section in the
/// Structures panel at the next frame (script command `panel`).
void set_panel_open(const std::string& structure, bool open);

}  // namespace fabrica::viewer
