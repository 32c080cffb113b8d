// The real editor under xvfb-run with the validation layer: open builtin:courtyard, bake the probe
// grid through the Bake panel's "Bake selection" action, wait, save screenshots (read back from the
// swapchain image) and the .pbake, then check both: the file attaches to a fresh courtyard, and the
// viewport changed where the lighting did (the indirect view marks those pixels) and nowhere else.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "penumbra/ao_field/ao_field.h"
#include "penumbra/core/pbake.h"
#include "penumbra/import/gltf.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/builtin.h"
#include "stb_image.h"

namespace {

namespace fs = std::filesystem;

struct Png {
  int width = 0, height = 0;
  std::vector<unsigned char> rgb;
  float luminance(int x, int y) const {
    const unsigned char* p = &rgb[3 * (static_cast<std::size_t>(y) * width + x)];
    return 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2];
  }
};

Png load_png(const fs::path& path) {
  Png png;
  int channels = 0;
  unsigned char* data = stbi_load(path.c_str(), &png.width, &png.height, &channels, 3);
  if (data) {
    png.rgb.assign(data, data + static_cast<std::size_t>(png.width) * png.height * 3);
    stbi_image_free(data);
  }
  return png;
}

std::string run_command(const std::string& command, int& status) {
  std::string out;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) {
    status = -1;
    return out;
  }
  char buf[512];
  while (fgets(buf, sizeof buf, pipe)) out += buf;
  status = pclose(pipe);
  return out;
}

// A fresh scratch folder for one test.
fs::path scratch_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// The editor at 1280x720 under xvfb-run with the validation layer, on lavapipe unless the caller
// chose a driver, running `script`; its output (also printed) and exit status.
std::string run_editor(const fs::path& script, int& status) {
  const char* driver = std::getenv("VK_DRIVER_FILES");
  const std::string env = driver ? "" : "VK_DRIVER_FILES=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json ";
  const std::string output = run_command(env + "xvfb-run -a -s '-screen 0 1280x720x24' " PENUMBRA_EDITOR_PATH
                                               " --validation --size 1280x720 --script " + script.string() + " 2>&1",
                                         status);
  std::printf("%s", output.c_str());
  return output;
}

TEST(EditorXvfb, BakesTheCourtyardThroughTheUiAndSavesScreenshotAndBake) {
  ASSERT_EQ(std::system("command -v xvfb-run > /dev/null"), 0) << "xvfb-run is missing: apt-get install xvfb xauth";
  const fs::path dir = scratch_dir("penumbra_editor_xvfb");
  const std::string d = dir.string();
  {
    std::ofstream script(dir / "bake.txt");
    script << "open builtin:courtyard draft\n"
              "frames 3\n"
              "ui off\n"
              "screenshot " << d << "/before.png\n"
              "ui on\n"
              "select \"probe grid\"\n"
              "expect-bake \"probe grid\" never-baked\n"
              "bake selection draft\n"
              "wait\n"
              "frames 2\n"
              "expect-bake \"probe grid\" up-to-date\n"
              "ui off\n"
              "screenshot " << d << "/after.png\n"
              "view indirect\n"
              "screenshot " << d << "/indirect.png\n"
              "view lit\n"
              "ui on\n"
              "frames 2\n"
              "screenshot " << d << "/editor.png\n"
              "save-bake " << d << "/courtyard.pbake\n"
              // The lit view against the offline reference of this frame, in the background.
              "reference-map 8\n"
              // The walker keeps walking: still up to date; the sun's change makes the grid out
              // of date.
              "frames 10\n"
              "expect-bake \"probe grid\" up-to-date\n"
              "set sun Light.intensity 5\n"
              "frames 2\n"
              "expect-bake \"probe grid\" out-of-date\n"
              "screenshot " << d << "/stale.png\n"
              "quit\n";
  }
  int status = 0;
  const std::string output = run_editor(dir / "bake.txt", status);
  ASSERT_EQ(status, 0) << output;  // includes: no validation message
  EXPECT_NE(output.find("validation messages: 0"), std::string::npos);
  // The reference map's line: the lit view (only the probe grid baked) within 40 % of the
  // reference's luminance.
  const std::size_t ratio_at = output.find("x the reference's");
  ASSERT_NE(ratio_at, std::string::npos) << output;
  const double ratio = std::stod(output.substr(output.rfind(' ', ratio_at - 1) + 1));
  EXPECT_GT(ratio, 0.6) << output;
  EXPECT_LT(ratio, 1.4) << output;

  // The saved .pbake holds what the editor baked, and a game's runtime attaches it to a fresh
  // courtyard (the same keys).
  auto file = penumbra::read_bake_file(dir / "courtyard.pbake");
  ASSERT_TRUE(file.ok()) << file.error().message;
  ASSERT_FALSE(file->chunks.empty());
  penumbra::World fresh;
  penumbra::register_lighting(fresh);
  ASSERT_TRUE(penumbra::load_builtin(fresh, "courtyard").ok());
  fresh.update(0.0);
  ASSERT_TRUE(penumbra::add_default_lighting(fresh, penumbra::Preset::Medium, false).ok());
  const penumbra::Status attached = penumbra::attach_bake(fresh, *file);
  EXPECT_TRUE(attached.ok()) << attached.error().message;

  // The screenshots: the whole window, read back from the swapchain.
  const Png before = load_png(dir / "before.png"), after = load_png(dir / "after.png");
  const Png indirect = load_png(dir / "indirect.png"), editor = load_png(dir / "editor.png");
  for (const Png* p : {&before, &after, &indirect, &editor}) {
    ASSERT_EQ(p->width, 1280);
    ASSERT_EQ(p->height, 720);
  }
  // Where the baked indirect light shows, the lit view got brighter; where it does not (the
  // background: the sky, black in the indirect view), nothing changed.
  double lit_change = 0.0, dark_change = 0.0;
  std::size_t lit = 0, dark = 0, brighter = 0;
  for (int y = 0; y < 720; ++y)
    for (int x = 0; x < 1280; ++x) {
      const float change = after.luminance(x, y) - before.luminance(x, y);
      if (indirect.luminance(x, y) > 24.0f) {
        lit_change += change;
        brighter += change > 2.0f;
        ++lit;
      } else if (indirect.luminance(x, y) < 1.0f) {
        dark_change += std::abs(change);
        ++dark;
      }
    }
  std::printf("lit pixels %zu: mean change %+.1f, %.0f%% brighter; background pixels %zu: mean |change| %.3f\n", lit,
              lit_change / double(lit), 100.0 * double(brighter) / double(lit), dark, dark_change / double(dark));
  ASSERT_GT(lit, 50000u);   // the courtyard covers a good part of the window
  ASSERT_GT(dark, 50000u);  // and the background the rest
  EXPECT_GT(lit_change / double(lit), 8.0);
  EXPECT_GT(double(brighter) / double(lit), 0.6);
  EXPECT_LT(dark_change / double(dark), 0.5);
  // The editor screenshot shows the panels (not just the viewport): it differs from the bare one.
  double ui_diff = 0.0;
  for (int y = 0; y < 720; ++y)
    for (int x = 0; x < 1280; ++x) ui_diff += std::abs(editor.luminance(x, y) - after.luminance(x, y));
  EXPECT_GT(ui_diff / (1280.0 * 720.0), 5.0);
  fs::remove_all(dir);
}

// The gizmo driven through the real pointer path (the script presses on the selected crate's +X
// arrow and drags 120 pixels along it): the crate moves along +X only, as one undoable edit of
// Transform.translation, and the screenshot shows it elsewhere; then the +Y ring turns it and the
// +Y scale arrow stretches it.
TEST(EditorXvfb, TheGizmoMovesTurnsAndScalesTheSelectionUndoably) {
  ASSERT_EQ(std::system("command -v xvfb-run > /dev/null"), 0) << "xvfb-run is missing: apt-get install xvfb xauth";
  const fs::path dir = scratch_dir("penumbra_editor_gizmo");
  const std::string d = dir.string();
  {
    std::ofstream script(dir / "gizmo.txt");
    script << "open builtin:courtyard draft\n"
              "frames 3\n"
              "select crate\n"
              "frames 2\n"
              "screenshot " << d << "/before.png\n"
              "drag-gizmo x 120\n"
              "frames 2\n"
              "screenshot " << d << "/after.png\n"
              "save-edits " << d << "/moved.txt\n"
              "undo\n"
              "save-edits " << d << "/undone.txt\n"
              "gizmo rotate\n"
              "drag-gizmo y 150\n"
              "gizmo scale\n"
              "drag-gizmo y 60\n"
              "frames 2\n"
              "save-edits " << d << "/turned.txt\n"
              "quit\n";
  }
  int status = 0;
  const std::string output = run_editor(dir / "gizmo.txt", status);
  ASSERT_EQ(status, 0) << output;
  const auto read = [](const fs::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  // The crate starts at (1, 0.4, 2) (builtin courtyard).
  const std::string moved = read(dir / "moved.txt");
  const std::size_t at = moved.find("Transform.translation ");
  ASSERT_NE(at, std::string::npos) << moved;
  float x = 0, y = 0, z = 0;
  ASSERT_EQ(std::sscanf(moved.c_str() + at, "Transform.translation %f %f %f", &x, &y, &z), 3) << moved;
  EXPECT_GT(x, 1.3f) << moved;
  EXPECT_NEAR(y, 0.4f, 1e-4f);
  EXPECT_NEAR(z, 2.0f, 1e-4f);
  EXPECT_EQ(moved.find("Transform.translation", at + 1), std::string::npos) << "one edit per drag: " << moved;
  EXPECT_EQ(read(dir / "undone.txt").find("Transform.translation"), std::string::npos);
  // The ring about +Y turns it about Y alone (degrees in the edit), the +Y arrow in scale mode
  // makes it taller alone.
  const std::string turned = read(dir / "turned.txt");
  const std::size_t rotation = turned.find("Transform.rotation "), scale = turned.find("Transform.scale ");
  ASSERT_NE(rotation, std::string::npos) << turned;
  ASSERT_NE(scale, std::string::npos) << turned;
  ASSERT_EQ(std::sscanf(turned.c_str() + rotation, "Transform.rotation %f %f %f", &x, &y, &z), 3) << turned;
  EXPECT_NEAR(x, 0.0f, 1e-3f);
  EXPECT_GT(std::abs(y), 10.0f) << turned;
  EXPECT_NEAR(z, 0.0f, 1e-3f);
  ASSERT_EQ(std::sscanf(turned.c_str() + scale, "Transform.scale %f %f %f", &x, &y, &z), 3) << turned;
  EXPECT_EQ(x, 1.0f);
  EXPECT_GT(y, 1.1f) << turned;
  EXPECT_EQ(z, 1.0f);
  const Png before = load_png(dir / "before.png"), after = load_png(dir / "after.png");
  ASSERT_EQ(before.width, after.width);
  double diff = 0.0;
  for (int y2 = 0; y2 < 720; ++y2)
    for (int x2 = 0; x2 < 1280; ++x2) diff += std::abs(after.luminance(x2, y2) - before.luminance(x2, y2));
  EXPECT_GT(diff / (1280.0 * 720.0), 0.2) << "the view should show the crate moved";
  fs::remove_all(dir);
}

// The path through the editor in one run: two built-in scenes, then a glTF file (a quad lit
// by a spot light); a probe grid and an AO-field caster added; the quad moved with the gizmo; a
// bake, after which everything is up to date; the spot light brightened, after which the grid is
// out of date (it holds the light) and the caster is not (AO reads no light); the quad duplicated,
// a light created, the camera node deleted; the scene saved as glTF and reopened with both
// components (never baked in the new document), the copy and the light. A screenshot at each step.
TEST(EditorXvfb, OpensEditsBakesAndSavesAStudiosScene) {
  ASSERT_EQ(std::system("command -v xvfb-run > /dev/null"), 0) << "xvfb-run is missing: apt-get install xvfb xauth";
  const fs::path dir = scratch_dir("penumbra_editor_path");
  const std::string d = dir.string();
  {
    std::ofstream script(dir / "path.txt");
    script << "open builtin:courtyard draft\n"
              "frames 2\n"
              "screenshot " << d << "/a.png\n"
              "open builtin:cornell draft\n"
              "frames 2\n"
              "screenshot " << d << "/b.png\n"
              "open " PENUMBRA_TEST_DATA "/gltf/valid.gltf\n"
              "frames 2\n"
              "ui off\n"
              "screenshot " << d << "/gltf.png\n"
              "ui on\n"
              "add root IrradianceProbeGrid\n"
              "add quad/0 AOFieldCaster\n"
              "expect-bake all never-baked\n"
              "select quad\n"
              "frames 2\n"
              "drag-gizmo y 40\n"
              "frames 2\n"
              "bake all draft\n"
              "wait\n"
              "frames 2\n"
              "expect-bake all up-to-date\n"
              "ui off\n"
              "screenshot " << d << "/baked.png\n"
              "ui on\n"
              "set spot Light.intensity 60\n"
              "frames 2\n"
              "expect-bake root out-of-date\n"
              "expect-bake quad/0 up-to-date\n"
              "ui off\n"
              "screenshot " << d << "/stale.png\n"
              "ui on\n"
              "save-edits " << d << "/edits.txt\n"
              "duplicate quad\n"
              "set \"quad (2)\" Transform.translation 1.5 1 0\n"
              "create point-light lamp\n"
              "set lamp Transform.translation 0 2 1\n"
              "delete eye\n"
              "frames 2\n"
              "ui off\n"
              "screenshot " << d << "/edited.png\n"
              "ui on\n"
              "save-gltf " << d << "/saved.gltf\n"
              "open " << d << "/saved.gltf\n"
              "frames 2\n"
              "expect-bake root never-baked\n"
              "expect-bake quad/0 never-baked\n"
              "select \"quad (2)\"\n"
              "select lamp\n"
              "screenshot " << d << "/reopened.png\n"
              "quit\n";
  }
  int status = 0;
  const std::string output = run_editor(dir / "path.txt", status);
  ASSERT_EQ(status, 0) << output;
  EXPECT_NE(output.find("validation messages: 0"), std::string::npos);
  std::ifstream in(dir / "edits.txt");
  const std::string edits((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(edits.find("Transform.translation"), std::string::npos) << "the gizmo's move: " << edits;
  EXPECT_NE(edits.find("Light.intensity 60"), std::string::npos) << edits;
  for (const char* shot : {"a", "b", "gltf", "baked", "stale", "edited", "reopened"}) {
    const Png png = load_png(dir / (std::string(shot) + ".png"));
    EXPECT_EQ(png.width, 1280) << shot;
    EXPECT_EQ(png.height, 720) << shot;
  }
  // Each open replaced what the window shows: the courtyard, the Cornell box, the glTF.
  const Png a = load_png(dir / "a.png"), b = load_png(dir / "b.png"), gltf = load_png(dir / "gltf.png");
  const auto mean_difference = [](const Png& p, const Png& q) {
    double sum = 0.0;
    for (int y = 0; y < 720; ++y)
      for (int x = 0; x < 1280; ++x) sum += std::abs(p.luminance(x, y) - q.luminance(x, y));
    return sum / (1280.0 * 720.0);
  };
  EXPECT_GT(mean_difference(a, b), 10.0);
  EXPECT_GT(mean_difference(b, gltf), 10.0);
  fs::remove_all(dir);
}

// File > Open of another scene while one is open, clicked as a user would (the script's click
// moves the pointer and presses the button): the document is replaced between frames, so nothing
// drawn that frame uses the old one, and the new scene is seen through its camera. Then a glTF
// character without lights or camera (an armature scaled by 0.01): framed by its skinned
// vertices, lit by the default light.
TEST(EditorXvfb, FileMenuOpensAnotherSceneAndThenALightlessCharacter) {
  ASSERT_EQ(std::system("command -v xvfb-run > /dev/null"), 0) << "xvfb-run is missing: apt-get install xvfb xauth";
  const fs::path dir = scratch_dir("penumbra_editor_open");
  const std::string d = dir.string();
  {
    std::ofstream script(dir / "open.txt");
    // The File menu at the top left; its first item is "Open builtin:cornell" (builtin_scene_names order).
    script << "open builtin:courtyard draft\n"
              "frames 3\n"
              "click 20 10\n"
              "screenshot " << d << "/menu.png\n"
              "click 60 33\n"
              "frames 3\n"
              "save-edits " << d << "/after_menu.txt\n"
              "ui off\n"
              "screenshot " << d << "/cornell.png\n"
              "ui on\n"
              "open " PENUMBRA_TEST_DATA "/gltf/scaled_armature.gltf\n"
              "frames 3\n"
              "ui off\n"
              "screenshot " << d << "/character.png\n"
              "ui on\n"
              // Lighting components added (one undone and redone), then the scene saved as glTF.
              "add Armature IrradianceProbeGrid\n"
              "set Armature IrradianceProbeGrid.spacing 0.25\n"
              "add body/0 AOFieldCaster\n"
              "undo\n"
              "redo\n"
              "save-gltf " << d << "/saved.gltf\n"
              "open " << d << "/saved.gltf\n"
              "frames 2\n"
              "quit\n";
  }
  int status = 0;
  const std::string output = run_editor(dir / "open.txt", status);
  ASSERT_EQ(status, 0) << output;
  EXPECT_NE(output.find("validation messages: 0"), std::string::npos);
  // The menu opened (its items cover part of the top-left panel), and the click on its first item
  // opened the Cornell box: the document's edits now start from it.
  std::ifstream edits(dir / "after_menu.txt");
  std::string text((std::istreambuf_iterator<char>(edits)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("open builtin:cornell"), std::string::npos) << text;
  // The Cornell box opens through its own camera: its red and green walls both in view (from the
  // orbit camera's default it would be seen from behind its back wall).
  const Png cornell = load_png(dir / "cornell.png");
  ASSERT_EQ(cornell.width, 1280);
  std::size_t red = 0, green = 0;
  for (std::size_t i = 0; i + 2 < cornell.rgb.size(); i += 3) {
    const int r = cornell.rgb[i], g = cornell.rgb[i + 1], b = cornell.rgb[i + 2];
    red += r > 40 && r > 2 * g && r > 2 * b;
    green += g > 40 && g > 2 * r && g > 2 * b;
  }
  std::printf("Cornell box through its camera: %zu red and %zu green wall pixels\n", red, green);
  EXPECT_GT(red, 20000u);
  EXPECT_GT(green, 20000u);
  // The character fills a good part of the bare viewport.
  const Png character = load_png(dir / "character.png");
  ASSERT_EQ(character.width, 1280);
  std::size_t covered = 0;
  for (int y = 0; y < character.height; ++y)
    for (int x = 0; x < character.width; ++x) covered += character.luminance(x, y) > 8.0f;
  const double share = double(covered) / (1280.0 * 720.0);
  std::printf("the character covers %.1f%% of the viewport\n", 100.0 * share);
  EXPECT_GT(share, 0.05);
  // The saved glTF declares what was added, and reopens with it.
  penumbra::World saved;
  penumbra::register_lighting(saved);
  auto loaded = penumbra::load_scene(saved, (dir / "saved.gltf").string());
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  ASSERT_TRUE(penumbra::apply_authored_lighting(saved).ok());
  std::size_t grids = 0, casters = 0;
  saved.each<penumbra::IrradianceProbeGrid>([&](penumbra::Entity, penumbra::IrradianceProbeGrid& g) {
    ++grids;
    EXPECT_EQ(g.spacing, 0.25f);
  });
  saved.each<penumbra::AOFieldCaster>([&](penumbra::Entity, penumbra::AOFieldCaster&) { ++casters; });
  EXPECT_EQ(grids, 1u);
  EXPECT_EQ(casters, 1u);
  fs::remove_all(dir);
}

// A click in the 3D view selects what is under the pointer, as a user would do it (the script's
// click presses and releases the button): through the courtyard's camera the ground below the
// middle, the north wall behind the crates, and nothing (the selection cleared) in the sky.
TEST(EditorXvfb, AClickSelectsWhatIsUnderThePointer) {
  ASSERT_EQ(std::system("command -v xvfb-run > /dev/null"), 0) << "xvfb-run is missing: apt-get install xvfb xauth";
  const fs::path dir = scratch_dir("penumbra_editor_pick");
  {
    std::ofstream script(dir / "pick.txt");
    script << "open builtin:courtyard draft\n"
              "frames 3\n"
              "click 614 470\n"
              "frames 1\n"
              "click 614 330\n"
              "frames 1\n"
              "click 614 40\n"
              "frames 1\n"
              "quit\n";
  }
  int status = 0;
  const std::string output = run_editor(dir / "pick.txt", status);
  ASSERT_EQ(status, 0) << output;
  const std::size_t ground = output.find("selected 'ground'"), wall = output.find("selected 'north_wall'"),
                    cleared = output.find("selection cleared");
  ASSERT_NE(ground, std::string::npos) << output;
  ASSERT_NE(wall, std::string::npos) << output;
  ASSERT_NE(cleared, std::string::npos) << output;
  EXPECT_LT(ground, wall);
  EXPECT_LT(wall, cleared);
  fs::remove_all(dir);
}

TEST(EditorXvfb, ABadScriptFailsNamingTheLineBeforeAnyWindowOpens) {
  const fs::path path = fs::temp_directory_path() / ("penumbra_editor_bad_" + std::to_string(::getpid()) + ".txt");
  {
    std::ofstream script(path);
    script << "open builtin:courtyard\nbake everything ultra\n";
  }
  int status = 0;
  // No display is needed: the script is checked first.
  const std::string output = run_command("DISPLAY= " PENUMBRA_EDITOR_PATH " --script " + path.string() + " 2>&1", status);
  EXPECT_NE(status, 0);
  EXPECT_NE(output.find(path.filename().string() + ":2: 'bake' takes"), std::string::npos) << output;
  fs::remove(path);
}

}  // namespace
