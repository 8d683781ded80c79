// weft.scene — what a frame draws: triangle meshes (OBJ/PLY/OFF/STL through OpenMesh, glTF
// 2.0 through tinygltf) made ready for shading (normals, tangents, the curvature the skin
// pass needs, validation and repair), procedural primitives, cameras, punctual lights, the
// environment light, and the JSON scene file that names them all. It knows no GPU.
//
// Conventions a user may want to know:
// - Right-handed, +Y up, metres; front faces are counter-clockwise; matrices are GLM's
//   (column-major, column vectors). Angles in scene files are degrees.
// - Meshes are flat vertex arrays: a vertex is split wherever its UV or normal differs
//   between faces (UV seams, hard edges). Processing that needs the surface's topology
//   (smooth normals, curvature) welds vertices with bit-identical positions first, so
//   seams never show in normals or curvature.
// - Expected failures are Errors naming the file and what is wrong; repairs that change a
//   mesh (degenerate triangles removed, normals recomputed, non-manifold faces) are logged
//   as warnings and kept in `warnings` of what was loaded. No exception leaves this module.
module;
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>
export module weft.scene;
import weft.core;
import weft.image;

export namespace weft::scene {

// ---- meshes ----------------------------------------------------------------------------

// An axis-aligned box; empty (min > max) until a point is added.
struct Bounds {
  vec3 min{std::numeric_limits<float>::infinity()};
  vec3 max{-std::numeric_limits<float>::infinity()};

  [[nodiscard]] bool empty() const { return !(min.x <= max.x && min.y <= max.y && min.z <= max.z); }
  void extend(const vec3& p) {
    min = glm::min(min, p);
    max = glm::max(max, p);
  }
  void extend(const Bounds& other) {
    if (other.empty()) return;
    extend(other.min);
    extend(other.max);
  }
  [[nodiscard]] vec3 center() const { return empty() ? vec3(0.0f) : (min + max) * 0.5f; }
  [[nodiscard]] vec3 size() const { return empty() ? vec3(0.0f) : max - min; }
  // The box around this box's eight corners moved by `m`.
  [[nodiscard]] Bounds transformed(const mat4& m) const;
};

// A triangle mesh ready for the GPU: every per-vertex array is either empty or has one entry
// per position (the curvature arrays and tangents are always filled by prepare_mesh).
struct Mesh {
  std::string name;
  std::vector<vec3> positions;
  std::vector<vec3> normals;    // unit length
  std::vector<vec4> tangents;   // xyz unit and orthogonal to the normal; w = +-1 handedness:
                                // bitangent = w * cross(normal, tangent.xyz) (glTF's rule);
                                // tangent along +u, bitangent towards the image's top (-v)
  std::vector<vec2> uvs;        // empty when the source had none; v = 0 is the image's top
                                // row (glTF's convention; OBJ's v is flipped on load)
  std::vector<vec2> uvs1;       // a second UV set (glTF's TEXCOORD_1), same convention; usually empty
  std::vector<std::uint32_t> indices;  // triangle list
  // Skin curvature (d'Eon & Luebke's |dn|/|dp|): per vertex, the mean over its edges of
  // |n_i - n_j| / |p_i - p_j|. 1/r on a sphere of radius r; >= 0; in 1/length units.
  std::vector<float> curvature;
  // Mean curvature H from the cotangent Laplacian: positive where the surface bends away
  // from its normal (1/r on a sphere with outward normals), 0 on a plane.
  std::vector<float> mean_curvature;
  // Gaussian curvature K from the angle defect (1/r^2 on a sphere, < 0 on saddles).
  std::vector<float> gaussian_curvature;
  // Principal curvatures (k1, k2) = H +- sqrt(max(H^2 - K, 0)), so k1 >= k2.
  std::vector<vec2> principal_curvatures;
  Bounds bounds;
  // What loading or repair changed or could not do (each one also logged as a warning).
  std::vector<std::string> warnings;

  [[nodiscard]] bool has_uvs() const { return !uvs.empty(); }
  [[nodiscard]] std::size_t vertex_count() const { return positions.size(); }
  [[nodiscard]] std::size_t triangle_count() const { return indices.size() / 3; }
};

struct LoadOptions {
  bool recompute_normals = false;      // ignore the file's normals; compute angle-weighted ones
  bool normalize_to_unit_box = false;  // centre on the origin, largest extent 1 (fits [-0.5, 0.5]^3)
};

// By extension (case-insensitive): .obj .ply .off .stl through OpenMesh, .gltf .glb through
// tinygltf (every instance of every mesh, placed by its node, merged into one mesh). Then
// prepare_mesh. Errors: NotFound, Unsupported (extension), Parse (corrupt file, indices out
// of range, non-finite positions: named with the vertex index), InvalidArgument (empty).
// OBJ face lines and whole PLY and OFF files are checked before OpenMesh reads them: its
// readers hang, run out of memory or abort on some corrupt input (see mesh_io.cpp).
[[nodiscard]] Result<Mesh> load_mesh(const std::filesystem::path& path, const LoadOptions& options = {});

// Validates and completes a mesh, in this order: errors for no vertices/triangles, index
// count not a multiple of 3, indices out of range, non-finite positions, per-vertex arrays
// of the wrong size; repairs (with a warning) non-finite normals/UVs and degenerate
// triangles (a repeated index or zero area: removed); optional unit-box normalisation;
// normals when missing, non-unit or asked for; tangents; curvature; bounds.
[[nodiscard]] Result<void> prepare_mesh(Mesh& mesh, const LoadOptions& options = {});

// The steps of prepare_mesh, for meshes built in code. Each expects a valid mesh.
void compute_normals(Mesh& mesh);     // angle-weighted, smooth across equal positions
void compute_tangents(Mesh& mesh);    // from UVs (per-triangle, Gram-Schmidt); without UVs
                                      // or where UVs are degenerate, any unit vector
                                      // orthogonal to the normal (w = 1)
void compute_curvature(Mesh& mesh);   // all four curvature arrays; see Mesh
[[nodiscard]] Bounds compute_bounds(std::span<const vec3> positions);
void normalize_to_unit_box(Mesh& mesh);

// Procedural meshes with normals, UVs, tangents and curvature. Arguments must be finite and
// positive (InvalidArgument otherwise); counts are clamped to [3, max_primitive_count]
// (plane: [1, max_primitive_count]). The limit keeps a primitive near a million vertices,
// which loads in seconds (4096 subdivisions made 16.8 million and took minutes).
inline constexpr std::uint32_t max_primitive_count = 1024;
// A UV sphere around the origin: `segments` around +Y, segments / 2 rings.
[[nodiscard]] Result<Mesh> make_sphere(float radius = 1.0f, std::uint32_t segments = 64);
// A square in the XZ plane at y = 0, facing +Y, `size` on a side, subdivisions^2 quads,
// UVs [0,1]^2 with u along +X and v along +Z.
[[nodiscard]] Result<Mesh> make_plane(float size = 1.0f, std::uint32_t subdivisions = 1);
// A torus around +Y: tube centre at `major_radius`, tube radius `minor_radius` (< major).
[[nodiscard]] Result<Mesh> make_torus(float major_radius = 1.0f, float minor_radius = 0.25f,
                                      std::uint32_t segments = 64, std::uint32_t sides = 32);
// An axis-aligned cube around the origin with hard edges (24 vertices), UVs [0,1]^2 a face.
[[nodiscard]] Result<Mesh> make_cube(float size = 1.0f);

// ---- camera, lights, environment ---------------------------------------------------------

struct Camera {
  vec3 position{0.0f, 1.0f, 5.0f};
  vec3 target{0.0f};
  vec3 up{0.0f, 1.0f, 0.0f};
  float fov_y_degrees = 45.0f;  // vertical field of view
  float near = 0.1f;
  float far = 100.0f;

  // World to view: right-handed, the camera looks down -Z.
  [[nodiscard]] mat4 view() const;
  // View to Vulkan clip space: y points down in NDC, depth 0 at `near` and 1 at `far`.
  [[nodiscard]] mat4 projection(float aspect) const;
  [[nodiscard]] vec3 forward() const;
};
// The largest output image side (scene files and `weft render --size`): 8192x8192 already
// needs about 2 GB of images (float scene colour, depth, readback); 16384x16384 needed 5 GB.
inline constexpr std::uint32_t max_output_side = 8192;
// The vertical field of view a camera may have, in degrees: narrower ones overflow the
// projection's precision (a fov of 1e-30 drew a quarter of the frame), wider ones are no
// longer a perspective a rasteriser can draw.
inline constexpr double min_fov_degrees = 0.01;
inline constexpr double max_fov_degrees = 179.0;
// InvalidArgument naming the field: non-finite values, fov outside [min_fov_degrees,
// max_fov_degrees], near <= 0, far <= near, position == target, up parallel to the view direction.
[[nodiscard]] Result<void> validate(const Camera& camera);
// A camera that looks at `bounds` from the +Z side, slightly above, far enough to see all.
[[nodiscard]] Camera camera_framing(const Bounds& bounds, float fov_y_degrees = 45.0f);

// Units follow glTF's KHR_lights_punctual: directional intensity is illuminance (lux),
// point and spot intensity is luminous intensity (candela). `color` is linear RGB.
// The limits keep every shaded value finite in 32-bit floats (an intensity of 1e38
// overflowed in the BRDF and drew black faces); the sun is about 1e5 lux.
inline constexpr double max_light_intensity = 1e7;
inline constexpr double max_light_color = 100.0;
struct DirectionalLight {
  std::string name;
  vec3 direction{0.0f, -1.0f, 0.0f};  // the direction the light travels (from the light)
  vec3 color{1.0f};
  float intensity = 1.0f;
};
struct PointLight {
  std::string name;
  vec3 position{0.0f};
  vec3 color{1.0f};
  float intensity = 1.0f;
  float range = 0.0f;  // distance where the light is cut off; 0 = infinite
};
struct SpotLight {
  std::string name;
  vec3 position{0.0f};
  vec3 direction{0.0f, -1.0f, 0.0f};  // the direction the light travels
  vec3 color{1.0f};
  float intensity = 1.0f;
  float range = 0.0f;
  float inner_cone_degrees = 0.0f;   // full intensity inside this angle from the axis
  float outer_cone_degrees = 45.0f;  // zero outside; inner < outer <= 90
};
using Light = std::variant<DirectionalLight, PointLight, SpotLight>;

// Light from every direction: the equirectangular `map` if present, else `constant_color`,
// both multiplied by `intensity`; `rotation_degrees` turns the map about +Y (see equirect_uv).
struct Environment {
  std::optional<image::Image> map;  // linear RGB, 3 channels, finite and non-negative
  std::filesystem::path source;     // where the map came from (empty for a constant)
  vec3 constant_color{0.0f};
  float intensity = 1.0f;
  float rotation_degrees = 0.0f;

  // Radiance arriving from `direction` (need not be unit), bilinear in the map; for CPU
  // references and tests.
  [[nodiscard]] vec3 radiance(const vec3& direction) const;
};
// The equirectangular mapping shared with shaders/frame.glsl and weft.frame: with
// c = cos(rotation), s = sin(rotation) and r = (c d.x + s d.z, d.y, -s d.x + c d.z) for a
// unit direction d, u = atan2(r.z, r.x) / (2 pi) + 0.5 and v = acos(r.y) / pi; v = 0 (the
// top row) is +Y. equirect_direction is its inverse.
[[nodiscard]] vec2 equirect_uv(const vec3& direction, float rotation_degrees = 0.0f);
[[nodiscard]] vec3 equirect_direction(const vec2& uv, float rotation_degrees = 0.0f);
// .hdr or .exr (any of weft.image's float formats). Gray becomes RGB, alpha is dropped;
// NaN, infinite and negative texels are set to 0 with a warning.
[[nodiscard]] Result<Environment> load_environment(const std::filesystem::path& path);

// ---- materials, objects ------------------------------------------------------------------

// A material's type is a name: "standard" (drawn by the forward pass) or the name of a
// feature (shell_fur, skin_sss, ...). The scene does not know the features; weft.feature's
// register_feature() registers each feature's name and its older aliases here, and scene
// files are checked against these names. Registration is for the whole process.
inline constexpr std::string_view standard_material = "standard";
// Adds a type (and aliases that resolve to it); InvalidArgument when a name is taken by
// another type. Registering the same name with the same aliases again changes nothing.
[[nodiscard]] Result<void> register_material_type(std::string_view name, std::span<const std::string> aliases = {});
// The type a scene file's name stands for ("fur" -> "shell_fur"), or nullopt when unknown.
[[nodiscard]] std::optional<std::string> resolve_material_type(std::string_view name);
// "standard" then the registered types in registration order, with aliases in parentheses:
// "standard, shell_fur (fur), skin_sss (skin)" — what an unknown type's error lists.
[[nodiscard]] std::string known_material_types();

// How a texture is sampled (glTF's sampler): wrap per axis and filters. Defaults are glTF's
// when a texture names no sampler: repeat, linear.
enum class TextureWrap : std::uint8_t { Repeat, ClampToEdge, MirroredRepeat };
enum class TextureFilter : std::uint8_t { Linear, Nearest };
struct TextureSampler {
  TextureWrap wrap_u = TextureWrap::Repeat;
  TextureWrap wrap_v = TextureWrap::Repeat;
  TextureFilter mag_filter = TextureFilter::Linear;
  TextureFilter min_filter = TextureFilter::Linear;
  bool operator==(const TextureSampler&) const = default;
};

// An image a material samples, decoded later by weft.image: a file, or (glTF data URIs and
// GLB buffer views) the encoded bytes themselves.
struct Texture {
  std::filesystem::path path;         // absolute or relative to the working folder; may be empty
  std::vector<std::uint8_t> encoded;  // PNG/JPEG bytes when embedded
  std::string mime_type;              // "image/png", "image/jpeg" or empty
  std::string label;                  // where embedded bytes came from, for messages ("glTF 'a.glb' image 2")
  std::uint32_t texcoord = 0;         // the UV set it reads: 0 = Mesh::uvs, 1 = Mesh::uvs1
  TextureSampler sampler;
  [[nodiscard]] bool empty() const { return path.empty() && encoded.empty(); }
};

// Metallic-roughness PBR (glTF's model). Colours are linear RGB.
struct StandardMaterial {
  vec3 base_color{0.8f};
  float alpha = 1.0f;
  Texture base_color_texture;          // sRGB; multiplies base_color
  float metallic = 0.0f;
  float roughness = 0.5f;
  Texture metallic_roughness_texture;  // linear: G = roughness, B = metallic (multiplies)
  Texture normal_texture;              // tangent space, linear; +Y (green) towards the image's top
  float normal_scale = 1.0f;
  Texture occlusion_texture;           // linear, R = ambient occlusion (dims image-based light only)
  float occlusion_strength = 1.0f;
  vec3 emissive{0.0f};                 // emitted radiance
  Texture emissive_texture;            // sRGB; multiplies emissive
};

struct Material {
  std::string name;
  std::string type{standard_material};  // resolved: a registered name, never an alias
  StandardMaterial standard;  // the fields of a standard material (defaults for others)
  // A feature material's fields other than "type", unparsed: each feature reads its own
  // knobs with a JsonReader on `params` at `json_path`, resolving paths against `base_dir`.
  nlohmann::json params = nlohmann::json::object();
  std::string json_path;           // e.g. "$.materials.fur" (empty when not from a file)
  std::filesystem::path base_dir;  // the scene file's folder
};

// Translation, rotation and scale, applied to a point as T * R * S.
struct Transform {
  vec3 translation{0.0f};
  quat rotation{1.0f, 0.0f, 0.0f, 0.0f};  // glm order: w, x, y, z
  vec3 scale{1.0f};
  [[nodiscard]] mat4 matrix() const;
  // Euler angles in degrees, applied about X, then Y, then Z (fixed axes): Rz * Ry * Rx.
  [[nodiscard]] static quat rotation_from_euler_degrees(const vec3& degrees);
};

// One thing to draw: a mesh and a material (indices into the scene's arrays) and where.
struct Object {
  std::string name;
  std::uint32_t mesh = 0;
  std::uint32_t material = 0;
  mat4 transform{1.0f};
};

// ---- glTF ------------------------------------------------------------------------------

struct GltfScene {
  std::filesystem::path source;
  std::vector<Mesh> meshes;            // one per primitive, named "<mesh>" or "<mesh>/<primitive>"
  std::vector<Material> materials;     // standard; plus "default" when a primitive has none
  std::vector<Object> instances;       // the node hierarchy flattened to world transforms
  std::vector<Camera> cameras;         // perspective cameras placed by their nodes
  std::vector<Light> lights;           // KHR_lights_punctual placed by their nodes
  std::vector<std::string> warnings;   // missing textures, skipped primitives, ... (logged too)
};
// The default scene (or the first; or every root node when the file has no scenes).
// Triangle lists, strips and fans are read (points and lines are skipped with a warning);
// indices u8/u16/u32; POSITION, NORMAL, TEXCOORD_0 and TEXCOORD_1 (float or normalised
// u8/u16), TANGENT. Every mesh goes through prepare_mesh. Materials keep all five
// metallic-roughness textures with their samplers and texCoord sets (0 or 1; a higher set is
// a warning and reads set 0); embedded images (data URIs, GLB buffer views) are kept as
// bytes, external ones are only checked for existence (missing: a warning naming the
// material and the path). Errors name the file: Parse for
// malformed JSON/GLB, out-of-range indices or accessors outside their buffers; Unsupported
// for sparse accessors, Draco and other required extensions.
[[nodiscard]] Result<GltfScene> load_gltf(const std::filesystem::path& path, const LoadOptions& options = {});

// ---- JSON reading ------------------------------------------------------------------------

// Every problem found in one JSON document, each at its JSON path.
class JsonErrors {
 public:
  void add(std::string_view json_path, std::string_view message);
  [[nodiscard]] bool empty() const { return lines_.empty(); }
  [[nodiscard]] std::size_t size() const { return lines_.size(); }
  [[nodiscard]] const std::vector<std::string>& lines() const { return lines_; }
  // A Parse error: "<source>: N problem(s)" then one "$.path: message" line per problem.
  [[nodiscard]] Error to_error(std::string_view source) const;

 private:
  std::vector<std::string> lines_;
};

// An inclusive (or, with the flags, exclusive) range for numbers: {.min = 1, .max = 256}.
struct Range {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_exclusive = false;
  bool max_exclusive = false;
};

// Reads one JSON object at a JSON path ("$.materials.fur"), field by field with defaults.
// A field that is present but has the wrong type or is out of range records an error
// naming its path in `errors` and gives the default, so a whole file is checked in one go.
// finish() records every field nothing asked about as unknown. The reader refers to the
// JSON value and the errors: both must outlive it. Copies share nothing but those.
class JsonReader {
 public:
  JsonReader(const nlohmann::json& value, std::string json_path, JsonErrors& errors,
             std::filesystem::path base_dir = {});

  [[nodiscard]] const nlohmann::json& json() const { return *value_; }
  [[nodiscard]] const std::string& json_path() const { return path_; }
  [[nodiscard]] const std::filesystem::path& base_dir() const { return base_dir_; }
  [[nodiscard]] JsonErrors& errors() const { return *errors_; }
  [[nodiscard]] bool is_object() const { return value_->is_object(); }
  // The JSON path of a field of this object: "$.a" + "b" -> "$.a.b" ("$.a['odd key']").
  [[nodiscard]] std::string path_of(std::string_view key) const;

  // Whether the field is present (and marks it known).
  [[nodiscard]] bool has(std::string_view key);
  // Records "missing required field" when absent; returns whether present.
  bool require(std::string_view key);
  // The raw value, or nullptr when absent (marks it known).
  [[nodiscard]] const nlohmann::json* value(std::string_view key);

  double number(std::string_view key, double fallback, Range range = {});
  // A number with no fractional part (15 and 15.0 both read as 15).
  std::int64_t integer(std::string_view key, std::int64_t fallback, Range range = {});
  bool boolean(std::string_view key, bool fallback);
  // With `choices`, anything else is an error listing them.
  std::string string(std::string_view key, std::string fallback = {},
                     std::initializer_list<std::string_view> choices = {});
  // Arrays of exactly N numbers, each in `range`.
  vec2 vec2_of(std::string_view key, vec2 fallback, Range range = {});
  vec3 vec3_of(std::string_view key, vec3 fallback, Range range = {});
  vec4 vec4_of(std::string_view key, vec4 fallback, Range range = {});
  // A string resolved against base_dir (absolute paths stay as they are); empty when absent.
  // With must_exist, a path that names no file is an error.
  std::filesystem::path path(std::string_view key, bool must_exist = true);

  // A nested object (nullopt when absent, or not an object: an error).
  [[nodiscard]] std::optional<JsonReader> object(std::string_view key);
  // The elements of an array, each as a reader at "$.key[i]" (empty when absent; an error
  // when not an array). Elements that must be objects are checked by the caller (is_object).
  [[nodiscard]] std::vector<JsonReader> array(std::string_view key);
  // This object as a map: every member as (name, reader at "$.path.name"), all marked known.
  [[nodiscard]] std::vector<std::pair<std::string, JsonReader>> members();
  // A copy of every member not named in `except`, all marked known: a feature's params.
  [[nodiscard]] nlohmann::json rest(std::initializer_list<std::string_view> except = {});

  // Records a problem at a field of this object, or at this object itself.
  void error_at(std::string_view key, std::string_view message);
  void error(std::string_view message);

  // Records every member never asked about: "unknown field (did you mean 'x'?)" or the
  // list of known fields. Call once, after reading everything.
  void finish();

 private:
  bool expect_object();
  const nlohmann::json* find(std::string_view key);

  const nlohmann::json* value_;
  std::string path_;
  JsonErrors* errors_;
  std::filesystem::path base_dir_;
  std::set<std::string, std::less<>> known_;
  bool reported_not_object_ = false;
};

// nlohmann's name of a JSON value's type: "number", "string", "array", "object", ...
[[nodiscard]] std::string_view json_type_name(const nlohmann::json& value);

// ---- scene files -------------------------------------------------------------------------

enum class PrimitiveKind : std::uint8_t { None, Sphere, Plane, Torus, Cube };

// Where a scene's mesh comes from: a file (path) or a primitive with its parameters.
struct MeshSource {
  std::string name;
  std::filesystem::path path;
  PrimitiveKind primitive = PrimitiveKind::None;
  float radius = 1.0f;          // sphere
  float size = 1.0f;            // plane, cube
  float major_radius = 1.0f;    // torus
  float minor_radius = 0.25f;   // torus
  std::uint32_t segments = 64;  // sphere, torus
  std::uint32_t sides = 32;     // torus
  std::uint32_t subdivisions = 1;  // plane
  LoadOptions options;
};

struct EnvironmentSource {
  std::filesystem::path hdr;  // equirectangular .hdr/.exr; empty = constant colour
  vec3 color{0.0f};
  float intensity = 1.0f;
  float rotation_degrees = 0.0f;
};

struct ObjectDesc {
  std::string name;
  std::uint32_t mesh = 0;      // index into SceneDesc::meshes
  std::uint32_t material = 0;  // index into SceneDesc::materials
  Transform transform;
};

struct Output {
  std::uint32_t width = 1280;
  std::uint32_t height = 720;
};

// A scene file, checked and resolved (paths absolute or relative to the working folder,
// names turned into indices) but nothing loaded. See docs/scene-format.md.
struct SceneDesc {
  std::filesystem::path source;  // the scene file; empty when parsed from text
  int version = 1;
  Output output;
  std::filesystem::path pipeline;  // the frame's pipeline file ("pipeline"); empty: the default one
  std::optional<Camera> camera;  // none: load_scene frames the scene's bounds
  EnvironmentSource environment;
  std::vector<Light> lights;
  std::vector<MeshSource> meshes;
  std::vector<Material> materials;  // includes "default" when an object names no material
  std::vector<ObjectDesc> objects;
};

// Parses a scene file's text; relative paths resolve against `base_dir`. Every problem of
// the file comes back in one Parse error, one per line, each with its JSON path; `source`
// names the file in that error.
[[nodiscard]] Result<SceneDesc> parse_scene(std::string_view json_text, const std::filesystem::path& base_dir,
                                            std::string_view source = "scene");
[[nodiscard]] Result<SceneDesc> load_scene_file(const std::filesystem::path& path);

// ---- loaded scenes -----------------------------------------------------------------------

struct Scene {
  std::filesystem::path source;
  Output output;
  std::filesystem::path pipeline;  // the pipeline file the scene names; empty: the default pipeline
  Camera camera;
  Environment environment;
  std::vector<Light> lights;
  std::vector<Mesh> meshes;
  std::vector<Material> materials;
  std::vector<Object> objects;
  std::vector<std::string> warnings;

  // Whether some object draws with a material of this type.
  [[nodiscard]] bool uses(std::string_view material_type) const;
  // World-space bounds of every object.
  [[nodiscard]] Bounds bounds() const;
};

// Loads what a SceneDesc names: mesh files, primitives, the environment map.
[[nodiscard]] Result<Scene> load_scene(const SceneDesc& desc);
// By extension: .json (a scene file), .gltf/.glb (its meshes, materials, lights and first
// camera), or a mesh file (one object with a default material). Scenes without a camera get
// camera_framing; scenes from a mesh or glTF without lights get one directional key light
// and a dim constant environment.
[[nodiscard]] Result<Scene> load_scene(const std::filesystem::path& path);
[[nodiscard]] Result<Scene> scene_from_gltf(GltfScene gltf);
// A JSON text's nesting depth and repeated keys, before a reader builds values from it: a
// Parse error naming the JSON path ("$.passes: the key 'bloom' appears twice in one
// object"). Syntax errors are left to the reader that follows. Scene, glTF and pipeline
// files share it.
[[nodiscard]] Result<void> check_json_text(std::string_view text, std::size_t max_depth);
// A whole text file (NotFound / Io errors name `what` and the path), as the scene reader reads one.
[[nodiscard]] Result<std::string> read_text_file(const std::filesystem::path& path, std::string_view what);

}  // namespace weft::scene

// Shared by this module's implementation units; not exported.
namespace weft::scene::detail {
// prepare_mesh with errors and warnings prefixed by `label` (a file path or "mesh 'x'").
[[nodiscard]] Result<void> prepare_mesh(Mesh& mesh, const LoadOptions& options, std::string_view label);
// load_gltf without prepare_mesh on its meshes.
[[nodiscard]] Result<GltfScene> read_gltf(const std::filesystem::path& path);
// Appends to `warnings` and logs it.
void warn(std::vector<std::string>& warnings, std::string message);
// ".obj" for "a/B.OBJ".
[[nodiscard]] std::string lowercase_extension(const std::filesystem::path& path);
// For every position, the index of the first position bit-identical to it (+0 == -0), and
// how many distinct positions there are.
struct Welding {
  std::vector<std::uint32_t> of;
  std::vector<vec3> positions;
};
[[nodiscard]] Welding weld(std::span<const vec3> positions);
// A unit vector orthogonal to the unit vector n (+X for n = +Y).
[[nodiscard]] vec3 any_orthogonal(const vec3& n);
// Checks of a mesh file's grammar before OpenMesh reads it (file_checks.cpp): Parse errors.
[[nodiscard]] Result<void> check_obj(const std::filesystem::path& path);
// A PLY file checked against its grammar: its bytes, and where each element's header lines
// and body data lie (byte offsets into `bytes`).
struct PlyLayout {
  struct Property {
    bool list = false;
    std::string count_type;  // lists only
    std::string type;
    std::string name;
  };
  struct Element {
    std::string name;
    std::size_t count = 0;
    std::vector<Property> properties;
    std::size_t header_begin = 0, header_end = 0;  // its "element" line up to the next element or end_header
    std::size_t body_begin = 0, body_end = 0;
  };
  std::vector<unsigned char> bytes;
  std::string format;  // "ascii", "binary_little_endian" or "binary_big_endian"
  std::size_t body_begin = 0;
  std::vector<Element> elements;
};
[[nodiscard]] Result<PlyLayout> check_ply(const std::filesystem::path& path);
// PLY scalar type sizes (0: unknown type) and one binary integer of a type.
[[nodiscard]] int ply_type_size(std::string_view type);
[[nodiscard]] long long ply_binary_integer(const unsigned char* p, std::string_view type, bool big_endian);
// A file that stores its faces as a 'tristrips' element (one vertex-index list per strip,
// -1 restarts the strip) rewritten with that element as a 'face' element of the strips'
// triangles, for OpenMesh (ply_strips.cpp); nullopt when the file has no 'tristrips'.
// Parse errors name the file and the element.
[[nodiscard]] Result<std::optional<std::string>> ply_strips_as_faces(const std::filesystem::path& path,
                                                                    const PlyLayout& layout);
[[nodiscard]] Result<void> check_off(const std::filesystem::path& path);
// A JSON text's nesting depth and repeated keys (json_checks.cpp): a Parse error naming
// the JSON path; syntax errors are left to the reader that follows.
[[nodiscard]] Result<void> check_json_structure(std::string_view text, std::size_t max_depth);
// Curvature of a valid mesh with normals; returns how many faces OpenMesh refused as
// non-manifold (left out of mean and Gaussian curvature).
std::size_t compute_curvature_counting(Mesh& mesh);
}  // namespace weft::scene::detail
