#include "penumbra/import/gltf.h"

#include <unistd.h>

#include <cmath>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "penumbra/core/random.h"
#include "penumbra/image/image.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/components.h"
#include "checkout_paths.h"

namespace penumbra {
namespace {

const std::filesystem::path kCases = std::filesystem::path(checkout::kSourceDir) / "tests/data/gltf";

std::size_t entity_count(World& world) {
  std::size_t n = 0;
  world.each<Name>([&](Entity, Name&) { ++n; });
  return n;
}

TEST(GltfImport, ValidSceneHierarchyPrimitivesMaterialsLightAndCamera) {
  World world;
  auto imported = import_gltf(world, kCases / "valid.gltf");
  ASSERT_TRUE(imported.ok()) << imported.error().message;
  EXPECT_EQ(imported->nodes.size(), 4u);
  EXPECT_EQ(imported->mesh_entities, 2u);  // one mesh, two primitives
  EXPECT_EQ(imported->triangles, 3u);      // 2 indexed + 1 non-indexed
  EXPECT_EQ(imported->lights, 1u);
  EXPECT_EQ(imported->cameras, 1u);
  EXPECT_EQ(imported->materials, 2u);
  EXPECT_EQ(imported->dropped_degenerate, 0u);

  // Hierarchy: root node under the import root, primitives under the mesh node.
  const Entity root_node = imported->nodes[0], quad_node = imported->nodes[1];
  ASSERT_TRUE(world.has<Parent>(root_node));
  EXPECT_EQ(world.get<Parent>(root_node).entity, imported->root);
  EXPECT_EQ(world.get<Parent>(quad_node).entity, root_node);
  ASSERT_TRUE(world.has<Children>(quad_node));
  const std::vector<Entity> prims = world.get<Children>(quad_node).entities;
  ASSERT_EQ(prims.size(), 2u);
  update_world_transforms(world);
  for (Entity p : prims) {
    ASSERT_TRUE(world.has<Mesh>(p));
    EXPECT_TRUE(world.has<Static>(p));
    EXPECT_TRUE(world.get<Mesh>(p).data->validate("prim").ok());
    EXPECT_NEAR(world.get<WorldTransform>(p).matrix[3].y, 1.0f, 0.0f);  // inherits the root's translation
  }
  EXPECT_NEAR(world.get<Material>(prims[0]).base_color.r, 0.5f, 1e-6f);
  // Emissive = emissiveFactor x KHR_materials_emissive_strength.
  const glm::vec3 emissive = world.get<Material>(prims[1]).emissive;
  EXPECT_NEAR(emissive.r, 4.0f, 1e-6f);
  EXPECT_NEAR(emissive.g, 2.0f, 1e-6f);
  EXPECT_NEAR(emissive.b, 1.0f, 1e-6f);
  // The second primitive had no normals: computed, facing +Y like its winding.
  for (const glm::vec3& n : world.get<Mesh>(prims[1]).data->normals) EXPECT_NEAR(n.y, 1.0f, 1e-6f);

  const Light& light = world.get<Light>(imported->nodes[2]);
  EXPECT_EQ(light.type, Light::Type::Spot);
  EXPECT_FLOAT_EQ(light.intensity, 30.0f);
  EXPECT_FLOAT_EQ(light.range, 10.0f);
  EXPECT_FLOAT_EQ(light.inner_cone_angle, 0.2f);
  EXPECT_FLOAT_EQ(light.outer_cone_angle, 0.5f);
  const Camera& camera = world.get<Camera>(imported->nodes[3]);
  EXPECT_FLOAT_EQ(camera.yfov, 0.7f);
  EXPECT_FLOAT_EQ(camera.aspect, 1.5f);
  EXPECT_FLOAT_EQ(camera.zfar, 50.0f);
}

TEST(GltfImport, ExternalBinMatchesEmbeddedBase64) {
  World a, b;
  auto embedded = import_gltf(a, kCases / "valid.gltf");
  auto external = import_gltf(b, kCases / "valid_external.gltf");
  ASSERT_TRUE(embedded.ok() && external.ok());
  const Entity pa = a.get<Children>(embedded->nodes[1]).entities[0];
  const Entity pb = b.get<Children>(external->nodes[1]).entities[0];
  EXPECT_EQ(a.get<Mesh>(pa).data->positions, b.get<Mesh>(pb).data->positions);
  EXPECT_EQ(a.get<Mesh>(pa).data->indices, b.get<Mesh>(pb).data->indices);
}

TEST(GltfImport, BinaryGlbMatchesExternalBin) {
  World a, b;
  auto embedded = import_gltf(a, kCases / "valid_external.gltf");
  auto binary = import_gltf(b, kCases / "valid.glb");
  ASSERT_TRUE(embedded.ok() && binary.ok()) << (binary.ok() ? "" : binary.error().message);
  const Entity pa = a.get<Children>(embedded->nodes[1]).entities[0];
  const Entity pb = b.get<Children>(binary->nodes[1]).entities[0];
  EXPECT_EQ(a.get<Mesh>(pa).data->positions, b.get<Mesh>(pb).data->positions);
  EXPECT_EQ(a.get<Mesh>(pa).data->normals, b.get<Mesh>(pb).data->normals);
  EXPECT_EQ(a.get<Mesh>(pa).data->indices, b.get<Mesh>(pb).data->indices);
}

TEST(GltfImport, MarkStaticCanBeTurnedOff) {
  World world;
  ImportOptions options;
  options.mark_static = false;
  ASSERT_TRUE(import_gltf(world, kCases / "valid.gltf", options).ok());
  EXPECT_EQ(world.count<Static>(), 0u);
}

TEST(GltfImport, DegenerateTrianglesAreDroppedAndCounted) {
  World world;
  auto imported = import_gltf(world, kCases / "degenerate.gltf");
  ASSERT_TRUE(imported.ok()) << imported.error().message;
  EXPECT_EQ(imported->dropped_degenerate, 2u);
  EXPECT_EQ(imported->triangles, 2u);
  ASSERT_EQ(imported->warnings.size(), 1u);
  EXPECT_NE(imported->warnings[0].find("degenerate.gltf: meshes[0].primitives[0]"), std::string::npos);
  EXPECT_NE(imported->warnings[0].find("2 degenerate"), std::string::npos);
}

struct BadCase {
  const char* file;
  ErrorCode code;
  std::vector<const char*> mentions;  // besides the file name
};

void PrintTo(const BadCase& c, std::ostream* os) { *os << c.file; }

class GltfMalformed : public ::testing::TestWithParam<BadCase> {};

TEST_P(GltfMalformed, FailsWithCodeFileAndElement) {
  const BadCase& c = GetParam();
  World world;
  auto imported = import_gltf(world, kCases / c.file);
  ASSERT_FALSE(imported.ok()) << c.file << " was accepted";
  EXPECT_EQ(imported.error().code, c.code) << imported.error().message;
  const std::string& message = imported.error().message;
  EXPECT_EQ(message.rfind((kCases / c.file).string(), 0), 0u) << "message must start with the file's path: " << message;
  for (const char* m : c.mentions) EXPECT_NE(message.find(m), std::string::npos) << "'" << m << "' not in: " << message;
  EXPECT_EQ(entity_count(world), 0u) << "a failed import must leave nothing behind";
}

INSTANTIATE_TEST_SUITE_P(
    Cases, GltfMalformed,
    ::testing::Values(
        BadCase{"missing_buffer.gltf", ErrorCode::NotFound, {"buffers[0]", "missing.bin"}},
        BadCase{"short_buffer.gltf", ErrorCode::InvalidInput, {"bufferViews[2]", "buffers[0]"}},
        BadCase{"accessor_past_view.gltf", ErrorCode::InvalidInput, {"accessors[0]", "bufferViews[0]", "POSITION"}},
        BadCase{"index_out_of_range.gltf", ErrorCode::InvalidInput, {"accessors[2]", "indices", "is 7"}},
        BadCase{"nan_position.gltf", ErrorCode::InvalidInput, {"accessors[0]", "POSITION", "NaN"}},
        BadCase{"inf_normal.gltf", ErrorCode::InvalidInput, {"accessors[1]", "NORMAL", "element 1"}},
        BadCase{"required_extension.gltf", ErrorCode::Unsupported, {"extensionsRequired", "KHR_draco_mesh_compression"}},
        BadCase{"bad_json.gltf", ErrorCode::InvalidInput, {"JSON"}},
        BadCase{"joint_out_of_range.gltf", ErrorCode::InvalidInput, {"JOINTS_0", "joint 5", "skins[0]", "nodes[1]"}},
        BadCase{"cycle.gltf", ErrorCode::InvalidInput, {"nodes[0]", "reachable twice"}},
        BadCase{"bad_key_times.gltf", ErrorCode::InvalidInput, {"animations[0].samplers[0].input", "key 2"}},
        BadCase{"truncated.glb", ErrorCode::InvalidInput, {"buffers[0]", "the binary chunk holds 68 bytes"}},
        BadCase{"does_not_exist.gltf", ErrorCode::NotFound, {"not found"}}),
    [](const ::testing::TestParamInfo<BadCase>& param_info) {
      std::string name = param_info.param.file;
      name = name.substr(0, name.find('.'));
      std::erase(name, '_');
      return name;
    });

// The Khronos sample character (../shared/assets, not copied into the repository).
// An accessor without a bufferView (all zeros by the spec) and a count of 2^40: refused at once,
// naming the limit, instead of looping over 2^40 zeros (it took 37 s and 3 GB at a count of 2e8).
TEST(GltfImport, HugeAccessorWithoutDataIsRefusedBeforeAnyWork) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("penumbra_huge_accessor_" + std::to_string(::getpid()) + ".gltf");
  std::ofstream(path) << R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0}], "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
    "accessors": [{"componentType": 5126, "type": "VEC3", "count": 1099511627776,
                   "min": [0, 0, 0], "max": [0, 0, 0]}]})";
  World world;
  auto imported = import_gltf(world, path);
  std::filesystem::remove(path);
  ASSERT_FALSE(imported.ok());
  EXPECT_EQ(imported.error().code, ErrorCode::InvalidInput);
  EXPECT_NE(imported.error().message.find("accessors[0]"), std::string::npos) << imported.error().message;
  EXPECT_NE(imported.error().message.find("exceeds the importer's limit of 134217728 elements"), std::string::npos)
      << imported.error().message;
}

// JSON nested 20,000 levels deep in `extras` (it overflowed the stack inside the JSON parsers) and a
// binary glTF of version 1 are refused before any parser runs, naming the file and the limit.
TEST(GltfImport, DeepJsonAndOtherGlbVersionsAreRefusedBeforeParsing) {
  const auto temp = [](const char* name) {
    return std::filesystem::temp_directory_path() / ("penumbra_" + std::to_string(::getpid()) + "_" + name);
  };
  const std::filesystem::path deep = temp("deep.gltf");
  {
    std::ofstream out(deep);
    out << R"({"asset": {"version": "2.0", "extras": )";
    for (int i = 0; i < 20000; ++i) out << "[";
    for (int i = 0; i < 20000; ++i) out << "]";
    out << "}}";
  }
  World world;
  auto nested = import_gltf(world, deep);
  std::filesystem::remove(deep);
  ASSERT_FALSE(nested.ok());
  EXPECT_EQ(nested.error().code, ErrorCode::InvalidInput);
  EXPECT_NE(nested.error().message.find("nested more than 128 levels"), std::string::npos) << nested.error().message;
  // A string holding brackets is not nesting.
  const std::filesystem::path brackets = temp("brackets.gltf");
  std::ofstream(brackets) << R"({"asset": {"version": "2.0", "extras": {"note": "[[[[[[[[ \" {{{{"}}, "scenes": []})";
  auto fine = import_gltf(world, brackets);
  std::filesystem::remove(brackets);
  EXPECT_TRUE(fine.ok() || fine.error().message.find("nested") == std::string::npos) << fine.error().message;

  const std::filesystem::path v1 = temp("v1.glb");
  {
    std::ofstream out(v1, std::ios::binary);
    const std::uint32_t header[5] = {0x46546C67u, 1u, 40u, 8u, 0x4E4F534Au};
    out.write(reinterpret_cast<const char*>(header), sizeof header);
    out << "{}      ";
  }
  auto old = import_gltf(world, v1);
  std::filesystem::remove(v1);
  ASSERT_FALSE(old.ok());
  EXPECT_EQ(old.error().code, ErrorCode::Unsupported);
  EXPECT_NE(old.error().message.find("binary glTF version 1"), std::string::npos) << old.error().message;
}

// The structural pre-check refuses, before tinygltf decodes anything, what it used to accept or
// crash on: negative offsets and strides (they were read as 0), a stride the specification does
// not allow, an image's bufferView far past its buffer (a heap over-read in the image decoder),
// and a .glb whose binary chunk is shorter than its buffer's byteLength; each error names the
// file's path, the element and the value (an accessor's type in words).
TEST(GltfImport, StructureIsCheckedBeforeDecoding) {
  nlohmann::json base;
  std::ifstream(kCases / "valid.gltf") >> base;
  struct Mutation {
    const char* what;
    void (*apply)(nlohmann::json&);
    std::vector<const char*> mentions;
  };
  const Mutation mutations[] = {
      {"negative view offset", [](nlohmann::json& j) { j["bufferViews"][1]["byteOffset"] = -16; },
       {"bufferViews[1].byteOffset is -16", "not an integer >= 0"}},
      {"negative accessor offset", [](nlohmann::json& j) { j["accessors"][0]["byteOffset"] = -4; },
       {"accessors[0].byteOffset is -4"}},
      {"negative stride", [](nlohmann::json& j) { j["bufferViews"][0]["byteStride"] = -12; },
       {"bufferViews[0].byteStride is -12"}},
      {"odd stride", [](nlohmann::json& j) { j["bufferViews"][0]["byteStride"] = 6; },
       {"bufferViews[0].byteStride is 6", "multiples of 4"}},
      {"image past its buffer",
       [](nlohmann::json& j) {
         j["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 4000000000u}, {"byteLength", 64}});
         j["images"] = nlohmann::json::array({{{"bufferView", j["bufferViews"].size() - 1}, {"mimeType", "image/png"}}});
       },
       {"run past the end of buffers[0]"}},
      {"image of no view", [](nlohmann::json& j) { j["images"] = {{{"bufferView", 99}, {"mimeType", "image/png"}}}; },
       {"images[0].bufferView is 99"}},
      {"view of no buffer", [](nlohmann::json& j) { j["bufferViews"][0]["buffer"] = 3; }, {"bufferViews[0].buffer is 3"}},
      {"view without buffer", [](nlohmann::json& j) { j["bufferViews"][0].erase("buffer"); },
       {"bufferViews[0] names no buffer"}},
      {"zero count", [](nlohmann::json& j) { j["accessors"][0]["count"] = 0; }, {"accessors[0].count is 0"}},
      {"long buffer", [](nlohmann::json& j) { j["buffers"][0]["byteLength"] = 100000; },
       {"buffers[0]: byteLength is 100000", "data URI decodes to"}},
      {"positions as bytes", [](nlohmann::json& j) { j["accessors"][0]["componentType"] = 5121; },
       {"accessors[0]", "is VEC3 of unsigned bytes", "it takes VEC3 of floats"}},
      {"buffer without uri in a .gltf", [](nlohmann::json& j) { j["buffers"][0].erase("uri"); },
       {"buffers[0] has no 'uri'", "no binary chunk", "data: URI"}},
  };
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("penumbra_structure_" + std::to_string(::getpid()) + ".gltf");
  for (const Mutation& m : mutations) {
    nlohmann::json j = base;
    m.apply(j);
    std::ofstream(path) << j.dump();
    World world;
    auto imported = import_gltf(world, path);
    ASSERT_FALSE(imported.ok()) << m.what << " was accepted";
    EXPECT_EQ(imported.error().code, ErrorCode::InvalidInput) << m.what;
    EXPECT_EQ(imported.error().message.rfind(path.string(), 0), 0u) << imported.error().message;
    for (const char* s : m.mentions)
      EXPECT_NE(imported.error().message.find(s), std::string::npos) << m.what << ": '" << s << "' not in "
                                                                      << imported.error().message;
  }
  std::filesystem::remove(path);

  // A .glb cut inside its binary chunk: the buffer's byteLength is more than the chunk holds.
  std::ifstream in(kCases / "valid.glb", std::ios::binary);
  std::string glb((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(glb.size(), 64u);
  const std::filesystem::path cut =
      std::filesystem::temp_directory_path() / ("penumbra_cut_" + std::to_string(::getpid()) + ".glb");
  std::ofstream(cut, std::ios::binary) << glb.substr(0, glb.size() - 16);
  World world;
  auto imported = import_gltf(world, cut);
  std::filesystem::remove(cut);
  ASSERT_FALSE(imported.ok());
  EXPECT_NE(imported.error().message.find("the binary chunk holds"), std::string::npos) << imported.error().message;

  // A folder is named as one, not as a missing file; a missing file's message has the full path.
  auto folder = import_gltf(world, std::filesystem::temp_directory_path());
  ASSERT_FALSE(folder.ok());
  EXPECT_NE(folder.error().message.find("is a folder"), std::string::npos) << folder.error().message;
  auto missing = import_gltf(world, "no_such_scene.glb");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find(std::filesystem::absolute("no_such_scene.glb").string()), std::string::npos)
      << missing.error().message;
}

// A light with a negative intensity is refused naming the light and the fix.
// PENUMBRA_lighting: the importer keeps each node's declarations as written (the lighting layer
// turns them into components: runtime.h, apply_authored_lighting) and refuses what it cannot read.
TEST(GltfImport, LightingExtensionIsKeptPerNodeAndItsShapeChecked) {
  World world;
  auto imported = import_gltf(world, kCases / "lighting_extension.gltf");
  ASSERT_TRUE(imported.ok()) << imported.error().message;
  std::size_t declared = 0;
  world.each<AuthoredLighting, Name>([&](Entity, AuthoredLighting& a, Name& n) {
    ++declared;
    ASSERT_EQ(a.components.size(), 1u);
    EXPECT_NE(a.source.find("lighting_extension.gltf: nodes["), std::string::npos) << a.source;
    if (n.value == "crate") {
      EXPECT_EQ(a.components[0].type, "AOFieldCaster");
      EXPECT_EQ(a.components[0].preset, "draft");
      EXPECT_EQ(a.meshes.size(), 1u);  // the crate's one primitive
      ASSERT_EQ(a.components[0].fields.size(), 1u);
      EXPECT_EQ(a.components[0].fields[0].first, "falloff_distance");
      EXPECT_EQ(std::get<double>(a.components[0].fields[0].second), 1.5);
    } else {
      EXPECT_EQ(n.value, "probes");
      EXPECT_TRUE(a.meshes.empty());
      EXPECT_EQ(std::get<std::string>(a.components[0].fields[0].second), "L1");  // by name: sh_order, then spacing
    }
  });
  EXPECT_EQ(declared, 2u);

  nlohmann::json base;
  std::ifstream(kCases / "lighting_extension.gltf") >> base;
  struct Mutation {
    const char* what;
    void (*apply)(nlohmann::json&);
    ErrorCode code;
    std::vector<const char*> mentions;
  };
  const Mutation mutations[] = {
      {"newer version", [](nlohmann::json& j) { j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["version"] = 2; },
       ErrorCode::Unsupported, {"nodes[3] 'probes'.extensions.PENUMBRA_lighting", "version 2", "update Penumbra"}},
      {"no version", [](nlohmann::json& j) { j["nodes"][3]["extensions"]["PENUMBRA_lighting"].erase("version"); },
       ErrorCode::InvalidInput, {"has no \"version\""}},
      {"unknown key", [](nlohmann::json& j) { j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["lights"] = 1; },
       ErrorCode::InvalidInput, {"unknown key \"lights\""}},
      {"components not an object",
       [](nlohmann::json& j) { j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["components"] = {1, 2}; },
       ErrorCode::InvalidInput, {"\"components\" is missing or not an object"}},
      {"a field as an object",
       [](nlohmann::json& j) {
         j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["components"]["IrradianceProbeGrid"]["spacing"] = {{"a", 1}};
       },
       ErrorCode::InvalidInput, {"components.IrradianceProbeGrid.spacing", "is not a boolean, number, string"}},
      {"an array of strings",
       [](nlohmann::json& j) {
         j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["components"]["IrradianceProbeGrid"]["resolution"] = {"x"};
       },
       ErrorCode::InvalidInput, {"IrradianceProbeGrid.resolution", "element 0 is not a number"}},
      {"sky of two channels",
       [](nlohmann::json& j) { j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["environment"]["radiance"] = {0.1, 0.2}; },
       ErrorCode::InvalidInput, {"nodes[3] 'probes'.extensions.PENUMBRA_lighting.environment", "not 3 numbers"}},
      {"negative sky",
       [](nlohmann::json& j) {
         j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["environment"]["radiance"] = {0.1, -0.2, 0.3};
       },
       ErrorCode::InvalidInput, {"environment.radiance", "element 1 is not a finite number >= 0"}},
      {"sky with an unknown key",
       [](nlohmann::json& j) {
         j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["environment"] = {{"radiance", {0, 0, 0}}, {"colour", 1}};
       },
       ErrorCode::InvalidInput, {"environment", "unknown key \"colour\" (radiance, map, map_scale)"}},
      {"sky map that is not there",
       [](nlohmann::json& j) {
         j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["environment"] = {{"map", "penumbra_no_such_sky.exr"}};
       },
       ErrorCode::NotFound, {"environment.map", "penumbra_no_such_sky.exr", "is not a file"}},
      {"sky map that is not a name",
       [](nlohmann::json& j) { j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["environment"] = {{"map", 3}}; },
       ErrorCode::InvalidInput, {"environment.map", "is not a file name"}},
      {"sky scale without a map",
       [](nlohmann::json& j) {
         j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["environment"] = {{"radiance", {0, 0, 0}}, {"map_scale", 2}};
       },
       ErrorCode::InvalidInput, {"environment", "\"map_scale\" without a \"map\""}},
  };
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("penumbra_lighting_ext_" + std::to_string(::getpid()) + ".gltf");
  // A component declared with no fields (all defaults) is kept: tinygltf's values drop empty
  // objects, so the importer reads the extension from the raw JSON.
  {
    nlohmann::json j = base;
    j["nodes"][2]["extensions"]["PENUMBRA_lighting"]["components"]["AOFieldReceiver"] = nlohmann::json::object();
    std::ofstream(path) << j.dump();
    World w;
    ASSERT_TRUE(import_gltf(w, path).ok());
    std::size_t components = 0;
    w.each<AuthoredLighting, Name>([&](Entity, AuthoredLighting& a, Name& n) {
      if (n.value == "crate") components = a.components.size();
    });
    EXPECT_EQ(components, 2u);
  }
  // A sky on a node: "environment" alone (no components) gives the node's entity an Environment.
  {
    nlohmann::json j = base;
    j["nodes"][3]["extensions"]["PENUMBRA_lighting"] = {{"version", 1},
                                                         {"environment", {{"radiance", {0.2, 0.25, 0.35}}}}};
    std::ofstream(path) << j.dump();
    World w;
    auto r = import_gltf(w, path);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(world_environment(w).radiance, glm::vec3(0.2f, 0.25f, 0.35f));
    std::size_t declaring = 0;
    w.each<AuthoredLighting>([&](Entity, AuthoredLighting&) { ++declaring; });
    EXPECT_EQ(declaring, 1u);  // the crate's; the sky's node declares no components
  }
  // A sky map: "map" names an OpenEXR file relative to the glTF, "map_scale" multiplies it; a map
  // and a radiance together, or a map with a bad texel, are refused naming the element.
  {
    const std::filesystem::path exr =
        path.parent_path() / ("penumbra_lighting_sky_" + std::to_string(::getpid()) + ".exr");
    Image image;
    image.width = 4;
    image.height = 2;
    for (int i = 0; i < 8; ++i) {
      const float v = i < 4 ? 1.0f : 0.25f;  // the upper row, then the lower
      image.rgba32f.insert(image.rgba32f.end(), {v, 2.0f * v, 3.0f * v, 1.0f});
    }
    ASSERT_TRUE(write_image(image, exr.string()).ok());
    nlohmann::json j = base;
    j["nodes"][3]["extensions"]["PENUMBRA_lighting"] = {
        {"version", 1}, {"environment", {{"map", exr.filename().string()}, {"map_scale", 2.0}}}};
    std::ofstream(path) << j.dump();
    World w;
    auto r = import_gltf(w, path);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const Environment sky = world_environment(w);
    ASSERT_TRUE(sky.map_data);
    EXPECT_EQ(sky.map, exr.filename().string());
    EXPECT_EQ(sky.map_data->width, 4u);
    EXPECT_EQ(sky.toward({0.0f, 1.0f, 0.0f}), glm::vec3(2.0f, 4.0f, 6.0f));
    EXPECT_EQ(sky.toward({0.0f, -1.0f, 0.0f}), glm::vec3(0.5f, 1.0f, 1.5f));
    // Saved, the sky keeps its map's name and a new scale; reopened, the same texels.
    GltfEdits edits;
    GltfNodeEdit& edit = edits.nodes.emplace_back();
    edit.node = 3;
    edit.environment = sky;
    edit.environment->map_scale = 0.5f;
    const std::filesystem::path saved = path.parent_path() / ("penumbra_lighting_saved_" + std::to_string(::getpid()) + ".gltf");
    ASSERT_TRUE(save_gltf(path, saved, edits).ok());
    World reopened;
    ASSERT_TRUE(import_gltf(reopened, saved).ok());
    const Environment again = world_environment(reopened);
    ASSERT_TRUE(again.map_data);
    EXPECT_EQ(again.map_data->digest, sky.map_data->digest);
    EXPECT_EQ(again.toward({0.0f, 1.0f, 0.0f}), glm::vec3(0.5f, 1.0f, 1.5f));
    std::filesystem::remove(saved);

    j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["environment"]["radiance"] = {0.1, 0.1, 0.1};
    std::ofstream(path) << j.dump();
    World both;
    auto refused = import_gltf(both, path);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.error().message.find("gives both \"radiance\" and \"map\""), std::string::npos);
    j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["environment"].erase("radiance");
    j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["environment"]["map_scale"] = -2.0;
    std::ofstream(path) << j.dump();
    World scaled;
    auto bad_scale = import_gltf(scaled, path);
    ASSERT_FALSE(bad_scale.ok());
    EXPECT_NE(bad_scale.error().message.find("environment.map_scale"), std::string::npos) << bad_scale.error().message;
    j["nodes"][3]["extensions"]["PENUMBRA_lighting"]["environment"]["map_scale"] = 2.0;
    image.rgba32f[5] = -1.0f;  // texel (1, 0), green
    ASSERT_TRUE(write_image(image, exr.string()).ok());
    std::ofstream(path) << j.dump();
    World negative;
    auto bad = import_gltf(negative, path);
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("environment.map"), std::string::npos) << bad.error().message;
    EXPECT_NE(bad.error().message.find("texel (1, 0)"), std::string::npos) << bad.error().message;
    EXPECT_EQ(entity_count(negative), 0u);
    std::filesystem::remove(exr);
  }
  for (const Mutation& m : mutations) {
    nlohmann::json j = base;
    m.apply(j);
    std::ofstream(path) << j.dump();
    World w;
    auto r = import_gltf(w, path);
    ASSERT_FALSE(r.ok()) << m.what << " was accepted";
    EXPECT_EQ(r.error().code, m.code) << m.what;
    for (const char* s : m.mentions) EXPECT_NE(r.error().message.find(s), std::string::npos) << m.what << ": " << r.error().message;
    EXPECT_EQ(entity_count(w), 0u) << m.what;  // rolled back
  }
  std::filesystem::remove(path);
}

TEST(GltfImport, NegativeLightIntensityIsRefused) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("penumbra_dark_light_" + std::to_string(::getpid()) + ".gltf");
  std::ofstream(path) << R"({"asset": {"version": "2.0"}, "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": -5}]}},
    "scene": 0, "scenes": [{"nodes": [0]}],
    "nodes": [{"name": "lamp", "extensions": {"KHR_lights_punctual": {"light": 0}}}]})";
  World world;
  auto imported = import_gltf(world, path);
  std::filesystem::remove(path);
  ASSERT_FALSE(imported.ok());
  EXPECT_NE(imported.error().message.find("KHR_lights_punctual.lights[0]"), std::string::npos)
      << imported.error().message;
  EXPECT_NE(imported.error().message.find("is negative or not finite; give a value >= 0"), std::string::npos)
      << imported.error().message;
}

// Unsigned-byte weights without "normalized": true (the specification requires it; read raw they
// would be 255 where 1 is meant) are refused naming the accessor.
TEST(GltfImport, IntegerWeightsMustBeNormalized) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("penumbra_raw_weights_" + std::to_string(::getpid()) + ".gltf");
  std::ofstream(path) << R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "JOINTS_0": 1, "WEIGHTS_0": 2}}]}],
    "buffers": [{"byteLength": 60, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAAAA/wAAAP8AAAD/AAAA"}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 12},
                    {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "type": "VEC3", "count": 3, "min": [0, 0, 0], "max": [1, 1, 0]},
                  {"bufferView": 1, "componentType": 5121, "type": "VEC4", "count": 3},
                  {"bufferView": 2, "componentType": 5121, "type": "VEC4", "count": 3}]})";
  World world;
  auto imported = import_gltf(world, path);
  std::filesystem::remove(path);
  ASSERT_FALSE(imported.ok());
  EXPECT_NE(imported.error().message.find("accessors[2]"), std::string::npos) << imported.error().message;
  EXPECT_NE(imported.error().message.find("without \"normalized\": true"), std::string::npos) << imported.error().message;
}

TEST(GltfImport, CesiumManSkinAnimationAndPose) {
  const std::filesystem::path asset = std::filesystem::path(checkout::kSharedDir) / "assets/CesiumMan.glb";
  if (!std::filesystem::exists(asset)) GTEST_SKIP() << "shared asset folder absent: " << asset << " not found";
  World world;
  register_scene_systems(world);
  auto imported = import_gltf(world, asset);
  ASSERT_TRUE(imported.ok()) << imported.error().message;
  EXPECT_EQ(imported->skins, 1u);
  EXPECT_EQ(imported->animations, 1u);
  EXPECT_EQ(imported->textures, 1u);
  EXPECT_EQ(imported->triangles + imported->dropped_degenerate, 4672u);

  Entity body;
  world.each<Skin>([&](Entity e, Skin&) { body = e; });
  ASSERT_TRUE(body);
  const Skin& skin = world.get<Skin>(body);
  EXPECT_EQ(skin.joints.size(), 19u);
  EXPECT_FALSE(world.has<Static>(body));
  const MeshData& mesh = *world.get<Mesh>(body).data;
  EXPECT_EQ(mesh.positions.size(), 3273u);
  for (const glm::vec4& w : mesh.weights) EXPECT_NEAR(w.x + w.y + w.z + w.w, 1.0f, 1e-5f);

  // Texture decoded to RGBA8 with a plausible mean colour.
  const Material& material = world.get<Material>(body);
  ASSERT_TRUE(material.base_color_texture);
  const Texture& texture = *material.base_color_texture;
  EXPECT_EQ(texture.rgba8.size(), static_cast<std::size_t>(texture.width) * static_cast<std::size_t>(texture.height) * 4);
  for (int c = 0; c < 3; ++c) {
    EXPECT_GT(texture.average_linear[c], 0.0f);
    EXPECT_LT(texture.average_linear[c], 1.0f);
  }

  const AnimationClip& clip = (*world.get<Animator>(imported->root).clips)[0];
  EXPECT_GT(clip.duration, 0.5f);

  // Pose at two times: finite, and the animated poses differ from the bind pose and each other.
  std::vector<glm::vec3> a, b;
  world.update(0.0);
  skin_positions(mesh, world.get<SkinPose>(body), a);
  world.update(0.5);
  skin_positions(mesh, world.get<SkinPose>(body), b);
  float from_bind = 0.0f, between = 0.0f;
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    ASSERT_TRUE(std::isfinite(b[i].x + b[i].y + b[i].z));
    from_bind = std::max(from_bind, glm::distance(b[i], mesh.positions[i]));
    between = std::max(between, glm::distance(a[i], b[i]));
  }
  EXPECT_GT(from_bind, 0.05f);
  EXPECT_GT(between, 0.05f);
  // Still a person-sized figure (bounds of the posed mesh within 3 m).
  Aabb bounds;
  for (const glm::vec3& p : b) bounds.extend(p);
  EXPECT_LT(glm::length(bounds.extent()), 3.0f);
  EXPECT_GT(glm::length(bounds.extent()), 0.5f);
}

TEST(GltfImport, ImportIsDeterministic) {
  const std::filesystem::path asset = std::filesystem::path(checkout::kSharedDir) / "assets/CesiumMan.glb";
  if (!std::filesystem::exists(asset)) GTEST_SKIP() << "shared asset folder absent: " << asset << " not found";
  World w1, w2;
  auto a = import_gltf(w1, asset);
  auto b = import_gltf(w2, asset);
  ASSERT_TRUE(a.ok() && b.ok());
  std::vector<std::vector<glm::vec3>> pa, pb;
  w1.each<Mesh>([&](Entity, Mesh& m) { pa.push_back(m.data->positions); });
  w2.each<Mesh>([&](Entity, Mesh& m) { pb.push_back(m.data->positions); });
  EXPECT_EQ(pa, pb);
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Hostile input: corrupted copies of the valid files must import cleanly or fail with an error,
// never crash, and whatever imports must satisfy the MeshData invariants.
// Returns whether the corrupted file imported.
bool expect_survives(const std::string& bytes, const std::filesystem::path& path) {
  {
    std::ofstream out(path, std::ios::binary);
    out << bytes;
  }
  World world;
  auto imported = import_gltf(world, path);
  if (!imported.ok()) {
    EXPECT_EQ(imported.error().message.rfind(path.string(), 0), 0u) << imported.error().message;
    return false;
  }
  world.each<Mesh>([&](Entity, Mesh& m) { EXPECT_TRUE(m.data->validate("fuzzed").ok()); });
  return true;
}

TEST(GltfImport, CorruptedBinaryChunkNeverCrashes) {
  const std::string glb = read_file(kCases / "valid.glb");
  const std::filesystem::path out = std::filesystem::path(::testing::TempDir()) / "fuzzed_bin.glb";
  // The BIN chunk is the tail of the file; flip bytes only there so tinygltf's container parse succeeds.
  const std::size_t bin_start = glb.size() - 108;
  int imported = 0, rejected = 0;
  for (std::uint64_t seed = 0; seed < 200; ++seed) {
    Rng rng = Rng::stream(42, seed);
    std::string bytes = glb;
    for (int flips = 0; flips < 4; ++flips)
      bytes[bin_start + rng.next_u32() % 108] = static_cast<char>(rng.next_u32() & 0xff);
    (expect_survives(bytes, out) ? imported : rejected) += 1;
  }
  // Both outcomes occur: corrupted indices and NaNs are caught, harmless flips import.
  EXPECT_GT(imported, 0);
  EXPECT_GT(rejected, 0);
}

TEST(GltfImport, CorruptedJsonNumbersNeverCrash) {
  const std::string text = read_file(kCases / "valid.gltf");
  const std::filesystem::path out = std::filesystem::path(::testing::TempDir()) / "fuzzed_json.gltf";
  // Positions of the integer literals outside the base64 buffer.
  std::vector<std::pair<std::size_t, std::size_t>> numbers;
  for (std::size_t i = 0; i < text.size();) {
    if (std::isdigit(static_cast<unsigned char>(text[i])) && i > 0 && !std::isalnum(static_cast<unsigned char>(text[i - 1])) &&
        text[i - 1] != '+' && text[i - 1] != '/') {
      std::size_t j = i;
      while (j < text.size() && std::isdigit(static_cast<unsigned char>(text[j]))) ++j;
      if (j < text.size() && (text[j] == ',' || text[j] == '\n' || text[j] == ']' || text[j] == '}')) numbers.emplace_back(i, j - i);
      i = j;
    } else {
      ++i;
    }
  }
  ASSERT_GT(numbers.size(), 30u);
  const char* replacements[] = {"-1", "0", "1", "2", "3", "5", "7", "64", "100000", "4294967295", "99999999999"};
  int imported = 0, rejected = 0;
  for (std::uint64_t seed = 0; seed < 300; ++seed) {
    Rng rng = Rng::stream(7, seed);
    const auto [pos, len] = numbers[rng.next_u32() % numbers.size()];
    std::string bytes = text;
    bytes.replace(pos, len, replacements[rng.next_u32() % std::size(replacements)]);
    (expect_survives(bytes, out) ? imported : rejected) += 1;
  }
  EXPECT_GT(imported, 0);
  EXPECT_GT(rejected, 0);
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

TEST(GltfImport, BaseColourTextureDecodedWithLinearAverage) {
  World world;
  auto imported = import_gltf(world, kCases / "textured.gltf");
  ASSERT_TRUE(imported.ok()) << imported.error().message;
  EXPECT_EQ(imported->textures, 1u);
  const Entity prim = world.get<Children>(imported->nodes[1]).entities[0];
  const std::shared_ptr<const Texture>& texture = world.get<Material>(prim).base_color_texture;
  ASSERT_TRUE(texture);
  EXPECT_EQ(texture->width, 2);
  EXPECT_EQ(texture->height, 2);
  EXPECT_EQ(texture->rgba8, (std::vector<std::uint8_t>{255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 128, 128, 128, 255}));
  // Mean of the linear values: (1 + 0 + 0 + srgb(128)) / 4 per channel, with the sRGB EOTF
  // srgb(128) = ((128 / 255 + 0.055) / 1.055)^2.4.
  const double grey = std::pow((128.0 / 255.0 + 0.055) / 1.055, 2.4);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(texture->average_linear[c], (1.0 + grey) / 4.0, 1e-6);

  World plain;
  ImportOptions options;
  options.load_textures = false;
  auto untextured = import_gltf(plain, kCases / "textured.gltf", options);
  ASSERT_TRUE(untextured.ok()) << untextured.error().message;
  EXPECT_EQ(untextured->textures, 0u);
  EXPECT_FALSE(plain.get<Material>(plain.get<Children>(untextured->nodes[1]).entities[0]).base_color_texture);
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

TEST(GltfAnimations, AnAnimationFileIsRetargetedByJointName) {
  World world;
  auto character = import_gltf(world, kCases / "scaled_armature.gltf");
  ASSERT_TRUE(character) << character.error().message;
  ASSERT_FALSE(world.has<Animator>(character->root));  // the character comes without clips
  auto added = import_animations(world, kCases / "scaled_armature_wave.gltf");
  ASSERT_TRUE(added) << added.error().message;
  EXPECT_EQ(added->clips, 1u);
  EXPECT_EQ(added->channels, 1u);
  EXPECT_EQ(added->unmatched_channels, 1u);
  ASSERT_EQ(added->warnings.size(), 1u);
  EXPECT_NE(added->warnings[0].find("'rig:prop'"), std::string::npos) << added->warnings[0];
  // "rig:head" drives the character's "head"; the Animator goes on the hierarchy's root.
  EXPECT_EQ(added->animator, character->root);
  const Animator& animator = world.get<Animator>(added->animator);
  ASSERT_EQ(animator.clips->size(), 1u);
  const AnimationClip& wave = animator.clips->front();
  EXPECT_EQ(wave.name, "wave");
  EXPECT_FLOAT_EQ(wave.duration, 1.0f);
  ASSERT_EQ(wave.targets.size(), 1u);
  EXPECT_EQ(world.get<Name>(wave.targets[0]).value, "head");
  // A second file appends to the same Animator.
  auto again = import_animations(world, kCases / "scaled_armature_wave.gltf");
  ASSERT_TRUE(again);
  EXPECT_EQ(again->animator, added->animator);
  EXPECT_EQ(world.get<Animator>(added->animator).clips->size(), 2u);
}

TEST(GltfAnimations, AFileThatDrivesNothingOfTheSceneIsRefusedByName) {
  World world;
  ASSERT_TRUE(load_scene(world, "builtin:cornell"));
  auto added = import_animations(world, kCases / "scaled_armature_wave.gltf");
  ASSERT_FALSE(added);
  EXPECT_EQ(added.error().code, ErrorCode::InvalidInput);
  EXPECT_NE(added.error().message.find("scaled_armature_wave.gltf"), std::string::npos);
  EXPECT_NE(added.error().message.find("'rig:head'"), std::string::npos) << added.error().message;
  auto none = import_animations(world, kCases / "valid.gltf");
  ASSERT_FALSE(none);
  EXPECT_NE(none.error().message.find("has no animations"), std::string::npos);
}

}  // namespace
}  // namespace penumbra
