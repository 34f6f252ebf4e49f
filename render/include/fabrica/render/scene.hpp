// Scene: structures (a mesh each) with a role and a style, for
// focus-and-context illustration. Focus structures are shaded and carry the
// chosen line families; context structures are subdued: ghosted
// (transparent), silhouettes only, faded lines, so the focus reads first.
// SceneSpec is the JSON description (mesh paths instead of geometry).
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/lines/line_set.hpp"
#include "fabrica/render/lic.hpp"
#include "fabrica/render/render_mesh.hpp"

namespace fabrica::render {

/// Linear RGBA in [0,1].
struct Color {
  float r = 0.0f, g = 0.0f, b = 0.0f, a = 1.0f;
};

/// "#rrggbb" of the colour's r, g, b (clamped to [0,1], rounded).
std::string to_hex(const Color& color);

enum class Role { focus, context };
/// none: not drawn but still hides lines behind it; flat: constant colour;
/// lambert: headlight diffuse; toon: headlight diffuse in bands.
enum class Shading { none, flat, lambert, toon };
/// What happens to the hidden parts of lines.
enum class HiddenLines { omit, dashed, show };

struct LineStyle {
  Color color{0.0f, 0.0f, 0.0f, 1.0f};
  /// Full width in pixels of an image whose smaller side is
  /// RenderOptions::line_reference_size (1024 by default); scaled with the image.
  double width = 2.0;
  double contour_width_factor = 1.5;  ///< contours and boundaries are drawn wider
  double taper = 0.15;           ///< fraction of each open polyline's length tapered at both ends
  bool fade_by_strength = true;  ///< opacity multiplied by the vertex strength
  bool width_by_strength = false;
  HiddenLines hidden = HiddenLines::omit;
  double hidden_opacity = 0.35;  ///< for dashed/shown hidden lines
  double dash = 6.0;             ///< dash length in (reference) pixels
};

struct StructureStyle {
  Shading shading = Shading::lambert;
  Color color{0.93f, 0.87f, 0.80f, 1.0f};
  double opacity = 1.0;  ///< < 1: ghosted, order-independent transparency
  double ambient = 0.2;
  int toon_levels = 3;
  /// Line families drawn from Structure::lines (empty: all it holds).
  std::vector<LineFamily> families;
  LineStyle lines;
  bool hybrid_apparent_ridges = false;  ///< image-space apparent ridges (needs curvature)
  /// Surface LIC in the feature regions, multiplied into the shading
  /// (lic.hpp; opaque structures only; RenderOptions::lic holds its parameters).
  bool lic = false;
  /// Iterations of on-surface smoothing of the object-space lines
  /// (fabrica/lines/smooth.hpp); 0 = off.
  int smooth = 0;
};

/// Defaults: focus = Lambert, opaque, contours + apparent ridges; context =
/// pale, opacity 0.25, contours only at half opacity and thinner.
StructureStyle default_style(Role role);

/// Polylines that are not feature lines (e.g. hatching strokes), drawn with
/// their own style by the same line-quad pipeline as Structure::lines and
/// hidden-line tested the same way. Open polylines of points on the surface,
/// in the mesh's coordinates (mm); every vertex has strength 1.
/// StructureStyle::families does not filter them.
struct PolylineLayer {
  std::string name;
  LineStyle style;
  std::vector<std::vector<Vec3>> polylines;
};

struct Structure {
  std::string name;
  Role role = Role::focus;
  StructureStyle style;
  std::shared_ptr<const RenderMesh> mesh;
  LineSet lines;  ///< already extracted (fabrica::lines), in the mesh's coordinates
  /// When set, drawn instead of `lines`, without a copy (the viewer's frames
  /// draw the lines its worker published, which it keeps alive).
  std::shared_ptr<const LineSet> shared_lines;
  /// The lines drawn: *shared_lines when set, else `lines`.
  const LineSet& drawn_lines() const { return shared_lines ? *shared_lines : lines; }
  /// Drawn before (under) `lines`, in order.
  std::vector<PolylineLayer> polyline_layers;
};

/// A clipping plane for the context (issue 18, item 4): context structures
/// lose what lies on the side `normal` points to (points p with
/// (p - point) . normal > 0), so the focus shows through a cut; the focus is
/// never clipped. Scene JSON: "clip": {"point": [x, y, z], "normal": [x, y, z]}
/// (mm, the meshes' space; the normal need not be unit length).
struct ClipPlane {
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();
  /// True where p is kept.
  bool keeps(const Vec3& p) const { return (p - point).dot(normal) <= 0.0; }
};

/// The cutaway (issue 18, item 4; docs/rendering.md#cutaway): context
/// structures lose what lies in front of the focus (nearer than the focus's
/// front surface) inside the focus's screen footprint widened by
/// `margin_px`, and fade back in over the next `fade_px` pixels; opaque
/// context too. The focus is never cut. Distances in pixels of a picture
/// whose smaller side is RenderOptions::line_reference_size (1024), scaled
/// with the picture as line widths are. Scene JSON: "cutaway": {"enabled",
/// "margin_px", "fade_px", "rim", "rim_color"}.
struct Cutaway {
  bool enabled = false;
  double margin_px = 12.0;  ///< fully cut up to this distance from the focus's silhouette
  double fade_px = 8.0;     ///< then the context's opacity ramps back to 1 over this distance
  bool rim = false;         ///< a line along the outer border of the cut, on the context
  Color rim_color{0.15f, 0.15f, 0.15f, 1.0f};
};
/// Largest margin_px and fade_px (reference pixels).
inline constexpr double kCutawayMaxPx = 256.0;
/// Width of the rim line in reference pixels.
inline constexpr double kCutawayRimPx = 1.5;
/// The fraction of a context surface kept at `distance` pixels (of the
/// picture) from the focus's footprint, where it lies in front of the
/// focus: 0 up to the margin, a smoothstep up to margin + fade, then 1.
/// `scale` converts reference pixels to the picture's (the renderer's line
/// scale). The shader cutaway.glsl computes the same.
double cutaway_keep(const Cutaway& cutaway, double distance, double scale = 1.0);
/// Reads the "cutaway" object over `base` (strict: unknown keys, wrong
/// types and values out of range throw InputError naming `what`).
Cutaway cutaway_from_json(const nlohmann::json& j, const std::string& what, Cutaway base = {});
nlohmann::json cutaway_to_json(const Cutaway& cutaway);

struct Scene {
  std::vector<Structure> structures;
  Color background{1.0f, 1.0f, 1.0f, 1.0f};
  std::optional<ClipPlane> clip;  ///< applies to context structures
  Cutaway cutaway;                ///< applies to context structures
};

// ------------------------------------------------------------ JSON ----

/// `structures[].hatching` as an object (issue 21; docs/scene.md): how
/// `fabrica hatch SCENE.json` hatches the structure, with the names of its
/// flags ("method"; the ConFIS parameters contour_margin, convex_threshold,
/// concave_threshold, umbilic_threshold, spacing, min_weight, no_contours,
/// no_features; and min_length, max_length). A key that is not
/// given, or whose flag is given on the command line, takes the command
/// line's value. Validated when read (range, type, unknown key: InputError
/// naming the key).
struct HatchingSpec {
  std::string method;                     ///< "shading" or "confis"; empty: --method
  std::map<std::string, double> numbers;  ///< by key, e.g. "contour_margin"
  std::map<std::string, bool> flags;      ///< "no_contours", "no_features"
  bool operator==(const HatchingSpec&) const = default;
};

struct StructureSpec {
  std::string name;
  std::filesystem::path mesh;  ///< absolute, or relative to the scene file
  Role role = Role::focus;
  StructureStyle style;
  std::optional<Space> space;  ///< override of the file's coordinate tag
  /// Annotation label (issue 17, item 5): empty = the name with '_' as
  /// spaces; `show_label` false = no label (still in the legend).
  std::string label;
  bool show_label = true;
  /// Hatched by `fabrica hatch SCENE.json`; unset: the focus structures are.
  /// "hatching": {...} (an object) hatches it with `hatching_options`.
  std::optional<bool> hatching;
  HatchingSpec hatching_options;
  /// Whether `fabrica hatch` hatches this structure.
  bool hatched() const { return hatching.value_or(role == Role::focus); }
};

/// What the annotation draws over the picture (render/annotate.hpp); every
/// part off by default. `font_size` is in pixels of a picture whose smaller
/// side is 1024 (scaled with the output, as line widths are).
struct AnnotationSpec {
  bool labels = false;
  bool legend = false;
  bool scale_bar = false;
  bool orientation = false;
  double font_size = 18.0;
  bool any() const { return labels || legend || scale_bar || orientation; }
};

/// What the default camera frames: every structure, or the focus
/// structures only (the context may then be cut at the picture's edges).
enum class Frame { all, focus };

struct SceneSpec {
  std::vector<StructureSpec> structures;
  std::optional<Camera> camera;
  std::optional<AnatomicalView> view;
  /// Unset: focus when the scene has both focus and context structures
  /// (default_frame), else all.
  std::optional<Frame> frame;
  Color background{1.0f, 1.0f, 1.0f, 1.0f};
  bool transparent = false;
  AnnotationSpec annotation;
  /// Parameters of the surface LIC of the structures with `lic` (the
  /// caller passes them on as RenderOptions::lic, as `fabrica render` does).
  LicOptions lic;
  std::optional<ClipPlane> clip;
  Cutaway cutaway;
};

const char* to_string(Frame frame);
std::optional<Frame> parse_frame(std::string_view s);
/// `frame` if set, else focus when `spec` has focus and context structures, else all.
Frame default_frame(const SceneSpec& spec, std::optional<Frame> frame = std::nullopt);

/// A camera looking from the anatomical side `view` at the centre of `box`,
/// at the distance where the box's projected corners fill `fill` of the
/// picture (of its width or height, whichever is reached first): a tight
/// fit, unlike anatomical_camera's bounding sphere. Used to frame the focus;
/// the default 0.6 leaves room for the context around it.
Camera fit_camera(AnatomicalView view, const BoundingBox& box, Space space, int width = 1024,
                  int height = 1024, double fill = 0.6);

/// The colour of a named structure in fabrica's anatomical palette
/// (docs/segmentation.md: arteries red, veins blue, bone ivory, ...): the
/// name is matched case-insensitively, '_' and ' ' alike, by its exact entry
/// or else by the first keyword it contains (TotalSegmentator and 3D Slicer
/// names such as "aorta", "kidney_left", "iliac_artery_right",
/// "vertebrae_L3"). nullopt for an unknown name.
std::optional<Color> anatomical_color(std::string_view name);
/// A pale colour for structure number `index` when its name is unknown
/// (a fixed cycle of distinct hues).
Color cycle_color(std::size_t index);

const char* to_string(Role role);
const char* to_string(Shading shading);
const char* to_string(HiddenLines hidden);
std::optional<Role> parse_role(std::string_view s);
std::optional<Shading> parse_shading(std::string_view s);
std::optional<HiddenLines> parse_hidden_lines(std::string_view s);

/// Keys (all optional except structures[].mesh): background [r,g,b(,a)],
/// transparent, camera {...} (camera JSON), view "anterior"|..., frame
/// "focus"|"all", structures: [{name, mesh, role, space, shading, color,
/// opacity, ambient, toon_levels, lines: [families], line_color, line_width,
/// taper, fade, hidden, hybrid, smooth, lic, label: "text" | false,
/// hatching}], annotation {labels, legend, scale_bar, orientation: booleans,
/// font_size: pixels}, lic {kernel_length, noise_scale, strength}
/// (docs/lic.md), clip {point, normal}, cutaway {enabled, margin_px,
/// fade_px, rim, rim_color} (Cutaway).
/// Missing style keys take default_style(role). Relative mesh paths are
/// resolved against `base_dir`. Validation is strict: an unknown key or a
/// value of the wrong type throws InputError naming `what`, the JSON path
/// (e.g. structures[2].colour) and the closest known key ("did you mean").
SceneSpec scene_spec_from_json(const nlohmann::json& j, const std::filesystem::path& base_dir,
                               const std::string& what = "scene");
nlohmann::json scene_spec_to_json(const SceneSpec& spec);
SceneSpec read_scene_spec(const std::filesystem::path& path);
void write_scene_spec(const SceneSpec& spec, const std::filesystem::path& path);

}  // namespace fabrica::render
