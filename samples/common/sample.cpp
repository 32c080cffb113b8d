// The sample games' frame loop and helpers (sample.h).
#include "sample.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_vulkan.h>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <imgui.h>

#include <penumbra/bake/baker.h>
#include <penumbra/core/jobs.h>
#include <penumbra/core/pbake.h>
#include <penumbra/ecs/transform.h>
#include <penumbra/image/image.h>
#include <penumbra/import/gltf.h>
#include <penumbra/render/device.h>
#include <penumbra/render/overlay_pass.h>
#include <penumbra/render/renderer.h>
#include <penumbra/render/swapchain.h>
#include <penumbra/render/vk_util.h>
#include <penumbra/scene/animation.h>
#include <penumbra/runtime.h>
#include <penumbra/scene/builtin.h>
#include <penumbra/scene/components.h>
#include <penumbra/scene/entity_key.h>

namespace sample {

using namespace penumbra;
using vk::vk_struct;

namespace {

constexpr double kAutoplayStep = 1.0 / 30.0;  // seconds per scripted frame

// Frame and system timings over the run, for the overlay and the exit summary.
struct Timings {
  std::vector<double> frame_ms;
  std::map<std::string, std::vector<double>> system_ms;  // by system name, in name order

  void add(double frame, const World& world) {
    frame_ms.push_back(frame);
    for (const SystemInfo& s : world.systems()) system_ms[s.name].push_back(s.last_ms);
  }
  static double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  }
  // Median of the last `window` values (all when 0).
  static double recent_median(const std::vector<double>& v, std::size_t window) {
    const std::size_t n = window == 0 ? v.size() : std::min(window, v.size());
    return median(std::vector<double>(v.end() - static_cast<std::ptrdiff_t>(n), v.end()));
  }
  double systems_ms(std::size_t window) const {
    double sum = 0.0;
    for (const auto& [name, ms] : system_ms) sum += recent_median(ms, window);
    return sum;
  }
  void print(std::FILE* out, std::string_view program, std::uint32_t width, std::uint32_t height) const {
    std::fprintf(out, "%.*s: %zu frames at %ux%u, median frame %.1f ms; systems (median CPU ms per frame):",
                 static_cast<int>(program.size()), program.data(), frame_ms.size(), width, height,
                 median(frame_ms));
    for (const auto& [name, ms] : system_ms) std::fprintf(out, " %s %.3f", name.c_str(), median(ms));
    std::fprintf(out, "; all systems %.3f\n", systems_ms(0));
  }
};

bool has_display() {
  const char* x = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  return (x && *x) || (wayland && *wayland);
}

// The overlay: help, status, and (F2) the timings.
void draw_overlay(const Game& game, const Timings& timings, bool help, bool stats) {
  ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_Always);
  ImGui::SetNextWindowBgAlpha(0.55f);
  ImGui::Begin("##help", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoInputs |
                   ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoFocusOnAppearing);
  if (help) {
    for (const std::string& line : game.help()) ImGui::TextUnformatted(line.c_str());
    ImGui::TextUnformatted("F1 help on/off   F2 timings   Esc quit");
    ImGui::Separator();
  }
  ImGui::TextUnformatted(game.status().c_str());
  if (stats && !timings.frame_ms.empty()) {
    ImGui::Separator();
    ImGui::Text("frame %.1f ms (median of the last 60)", Timings::recent_median(timings.frame_ms, 60));
    for (const auto& [name, ms] : timings.system_ms)
      ImGui::Text("  %-20s %7.3f ms", name.c_str(), Timings::recent_median(ms, 60));
    ImGui::Text("  %-20s %7.3f ms", "all systems", timings.systems_ms(60));
  }
  ImGui::End();
}

Error vk_error(const char* what, VkResult r) {
  return make_error(ErrorCode::Internal, std::string(what) + " failed: " + vk::vk_result_name(r));
}

void check_imgui_vk(VkResult r) {
  if (r != VK_SUCCESS) std::fprintf(stderr, "imgui vulkan backend: VkResult %d\n", static_cast<int>(r));
}

// The window's Vulkan objects: Penumbra's device, swapchain and renderer, plus what the ImGui
// overlay needs (its descriptor pool and the SDK's OverlayPass over the renderer's frame).
struct WindowFrame {
  GLFWwindow* window = nullptr;
  std::unique_ptr<Device> device;
  std::unique_ptr<Swapchain> swapchain;
  std::unique_ptr<Renderer> renderer;
  VkDevice vk = VK_NULL_HANDLE;
  VkCommandPool pool = VK_NULL_HANDLE;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkDescriptorPool imgui_pool = VK_NULL_HANDLE;
  std::unique_ptr<OverlayPass> overlay;
  bool imgui_ready = false;

  ~WindowFrame() {
    if (vk) vkDeviceWaitIdle(vk);
    if (imgui_ready) ImGui_ImplVulkan_Shutdown();
    overlay.reset();
    if (imgui_pool) vkDestroyDescriptorPool(vk, imgui_pool, nullptr);
    if (pool) vkDestroyCommandPool(vk, pool, nullptr);
    renderer.reset();
    swapchain.reset();
  }

  Status init(GLFWwindow* w, bool validation) {
    window = w;
    DeviceOptions options;
    options.validation = validation;
    options.swapchain = true;
    std::uint32_t count = 0;
    const char** names = glfwGetRequiredInstanceExtensions(&count);
    for (std::uint32_t i = 0; i < count; ++i) options.instance_extensions.emplace_back(names[i]);
    auto created = Device::create(options);
    if (!created) return created.error();
    device = std::move(*created);
    vk = device->device();
    VkSurfaceKHR surface = VK_NULL_HANDLE;
    if (VkResult r = glfwCreateWindowSurface(device->instance(), window, nullptr, &surface); r != VK_SUCCESS)
      return vk_error("glfwCreateWindowSurface", r);
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(window, &fw, &fh);
    auto chain = Swapchain::create(*device, surface, static_cast<std::uint32_t>(std::max(fw, 1)),
                                   static_cast<std::uint32_t>(std::max(fh, 1)));
    if (!chain) return chain.error();
    swapchain = std::move(*chain);
    auto made = Renderer::create(*device);
    if (!made) return made.error();
    renderer = std::move(*made);

    auto pool_info = vk_struct<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
    pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pool_info.queueFamilyIndex = device->queue_family();
    if (VkResult r = vkCreateCommandPool(vk, &pool_info, nullptr, &pool); r != VK_SUCCESS)
      return vk_error("vkCreateCommandPool", r);
    auto cmd_info = vk_struct<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
    cmd_info.commandPool = pool;
    cmd_info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cmd_info.commandBufferCount = 1;
    if (VkResult r = vkAllocateCommandBuffers(vk, &cmd_info, &cmd); r != VK_SUCCESS)
      return vk_error("vkAllocateCommandBuffers", r);

    const VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 4}};
    auto dp = vk_struct<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
    dp.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
    dp.maxSets = 4;
    dp.poolSizeCount = 1;
    dp.pPoolSizes = sizes;
    if (VkResult r = vkCreateDescriptorPool(vk, &dp, nullptr, &imgui_pool); r != VK_SUCCESS)
      return vk_error("vkCreateDescriptorPool", r);
    auto pass = OverlayPass::create(*device, swapchain->format(), VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);
    if (!pass) return pass.error();
    overlay = std::move(*pass);

    ImGui_ImplVulkan_InitInfo init{};
    init.Instance = device->instance();
    init.PhysicalDevice = device->physical_device();
    init.Device = vk;
    init.QueueFamily = device->queue_family();
    init.Queue = device->queue();
    init.DescriptorPool = imgui_pool;
    init.MinImageCount = std::max(2u, swapchain->image_count());
    init.ImageCount = std::max(2u, swapchain->image_count());
    init.MSAASamples = VK_SAMPLE_COUNT_1_BIT;
    init.CheckVkResultFn = check_imgui_vk;
    if (!ImGui_ImplVulkan_Init(&init, overlay->render_pass()))
      return make_error(ErrorCode::Internal, "ImGui_ImplVulkan_Init failed");
    imgui_ready = true;
    PENUMBRA_TRY(device->submit_and_wait([](VkCommandBuffer c) { ImGui_ImplVulkan_CreateFontsTexture(c); }));
    ImGui_ImplVulkan_DestroyFontUploadObjects();
    return {};
  }

  Status resize() {
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(window, &fw, &fh);
    if (fw == 0 || fh == 0) return {};  // minimised
    overlay->release_framebuffers();
    return swapchain->resize(static_cast<std::uint32_t>(fw), static_cast<std::uint32_t>(fh));
  }

  // One frame: the world's image, the overlay on top, presented.
  Status draw(World& world, const CameraView& camera, ImDrawData* ui) {
    if (swapchain->out_of_date()) PENUMBRA_TRY(resize());
    auto acquired = swapchain->acquire();
    if (!acquired) return swapchain->out_of_date() ? resize() : Status(acquired.error());
    RenderTarget target = *acquired;
    target.final_layout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    PENUMBRA_TRY(renderer->sync(world));
    vkResetCommandBuffer(cmd, 0);
    auto begin = vk_struct<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vkBeginCommandBuffer(cmd, &begin);
    Status recorded = renderer->record(cmd, target, camera, RenderSettings{});
    if (recorded) recorded = overlay->begin(cmd, target);
    if (!recorded) {
      vkEndCommandBuffer(cmd);
      return recorded;
    }
    ImGui_ImplVulkan_RenderDrawData(ui, cmd);
    overlay->end(cmd);
    if (VkResult r = vkEndCommandBuffer(cmd); r != VK_SUCCESS) return vk_error("vkEndCommandBuffer", r);
    const Status presented = swapchain->present(cmd);
    if (!presented && !swapchain->out_of_date()) return presented;
    return {};
  }
};

Input keyboard_input(GLFWwindow* window, double dt, glm::dvec2& last_cursor) {
  Input in;
  const auto down = [window](int key) { return glfwGetKey(window, key) == GLFW_PRESS; };
  if (down(GLFW_KEY_W) || down(GLFW_KEY_UP)) in.move.y += 1.0f;
  if (down(GLFW_KEY_S) || down(GLFW_KEY_DOWN)) in.move.y -= 1.0f;
  if (down(GLFW_KEY_D) || down(GLFW_KEY_RIGHT)) in.move.x += 1.0f;
  if (down(GLFW_KEY_A) || down(GLFW_KEY_LEFT)) in.move.x -= 1.0f;
  if (down(GLFW_KEY_Q)) in.turn += 1.5f * static_cast<float>(dt);
  if (down(GLFW_KEY_E)) in.turn -= 1.5f * static_cast<float>(dt);
  glm::dvec2 cursor;
  glfwGetCursorPos(window, &cursor.x, &cursor.y);
  if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS ||
      glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS)
    in.turn -= 0.006f * static_cast<float>(cursor.x - last_cursor.x);
  last_cursor = cursor;
  if (glm::length(in.move) > 1.0f) in.move = glm::normalize(in.move);
  return in;
}

int run_windowed(std::string_view program, Game& game, const Options& options, std::FILE* report) {
  const std::string prog(program);
  if (!glfwInit()) {
    std::fprintf(stderr, "%s: glfwInit failed (no display? run with --headless)\n", prog.c_str());
    return 1;
  }
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  GLFWwindow* window = glfwCreateWindow(static_cast<int>(options.width), static_cast<int>(options.height),
                                        prog.c_str(), nullptr, nullptr);
  if (!window) {
    std::fprintf(stderr, "%s: glfwCreateWindow failed\n", prog.c_str());
    glfwTerminate();
    return 1;
  }
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForVulkan(window, true);
  int code = 0;
  {
    WindowFrame frame;
    Timings timings;
    if (Status s = frame.init(window, options.validation); !s) {
      std::fprintf(stderr, "%s: %s\n", prog.c_str(), s.error().message.c_str());
      code = 1;
    }
    bool help = true, stats = options.stats, f1 = false, f2 = false;
    glm::dvec2 cursor;
    glfwGetCursorPos(window, &cursor.x, &cursor.y);
    auto last = std::chrono::steady_clock::now();
    for (int n = 0; code == 0 && !glfwWindowShouldClose(window) && (options.frames == 0 || n < options.frames); ++n) {
      const auto start = std::chrono::steady_clock::now();
      const double wall_dt = std::min(std::chrono::duration<double>(start - last).count(), 0.1);
      last = start;
      glfwPollEvents();
      if (glfwGetKey(window, GLFW_KEY_ESCAPE) == GLFW_PRESS) break;
      const bool f1_now = glfwGetKey(window, GLFW_KEY_F1) == GLFW_PRESS;
      const bool f2_now = glfwGetKey(window, GLFW_KEY_F2) == GLFW_PRESS;
      if (f1_now && !f1) help = !help;
      if (f2_now && !f2) stats = !stats;
      f1 = f1_now;
      f2 = f2_now;
      const double dt = options.autoplay ? kAutoplayStep : wall_dt;
      const Input input = options.autoplay ? game.autoplay(n) : keyboard_input(window, dt, cursor);
      game.step(input, dt);
      game.world().update(dt);
      if (report) {
        std::fprintf(report, "frame=%d ", n);
        game.report(report);
        std::fputc('\n', report);
      }
      ImGui_ImplVulkan_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      draw_overlay(game, timings, help, stats);
      ImGui::Render();
      const VkExtent2D extent = frame.swapchain->extent();
      const CameraView camera =
          game.camera(static_cast<float>(extent.width) / static_cast<float>(std::max(extent.height, 1u)));
      if (Status s = frame.draw(game.world(), camera, ImGui::GetDrawData()); !s) {
        std::fprintf(stderr, "%s: frame %d: %s\n", prog.c_str(), n, s.error().message.c_str());
        code = 1;
        break;
      }
      timings.add(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count(),
                  game.world());
    }
    if (code == 0 && !options.screenshot.empty()) {
      const VkExtent2D extent = frame.swapchain->extent();
      const CameraView camera =
          game.camera(static_cast<float>(extent.width) / static_cast<float>(std::max(extent.height, 1u)));
      auto image = frame.renderer->render_image(game.world(), camera, extent.width, extent.height, RenderSettings{});
      const Status s = image ? write_image(*image, options.screenshot) : Status(image.error());
      if (!s) {
        std::fprintf(stderr, "%s: screenshot: %s\n", prog.c_str(), s.error().message.c_str());
        code = 1;
      } else {
        std::printf("%s: wrote %s\n", prog.c_str(), options.screenshot.c_str());
      }
    }
    if (code == 0 && frame.device && frame.device->validation_messages() > 0) {
      std::fprintf(stderr, "%s: %u validation messages, the last: %s\n", prog.c_str(),
                   frame.device->validation_messages(), frame.device->last_validation_message().c_str());
      code = 1;
    }
    if (code == 0) timings.print(stdout, prog, frame.swapchain->extent().width, frame.swapchain->extent().height);
  }
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(window);
  glfwTerminate();
  return code;
}

int run_headless(std::string_view program, Game& game, const Options& options, std::FILE* report) {
  const std::string prog(program);
  DeviceOptions device_options;
  device_options.validation = options.validation;
  auto device = Device::create(device_options);
  if (!device) {
    std::fprintf(stderr, "%s: %s\n", prog.c_str(), device.error().message.c_str());
    return 1;
  }
  auto renderer = Renderer::create(**device);
  if (!renderer) {
    std::fprintf(stderr, "%s: %s\n", prog.c_str(), renderer.error().message.c_str());
    return 1;
  }
  const float aspect = static_cast<float>(options.width) / static_cast<float>(options.height);
  Timings timings;
  for (int n = 0; n < options.frames; ++n) {
    const auto start = std::chrono::steady_clock::now();
    game.step(options.autoplay ? game.autoplay(n) : Input{}, kAutoplayStep);
    game.world().update(kAutoplayStep);
    if (report) {
      std::fprintf(report, "frame=%d ", n);
      game.report(report);
      std::fputc('\n', report);
    }
    const CameraView camera = game.camera(aspect);
    const bool last = n + 1 == options.frames;
    Status s;
    if (last && !options.screenshot.empty()) {
      auto image = (*renderer)->render_image(game.world(), camera, options.width, options.height, RenderSettings{});
      s = image ? write_image(*image, options.screenshot) : Status(image.error());
    } else {
      s = (*renderer)->render_frame(game.world(), camera, options.width, options.height, RenderSettings{});
    }
    if (!s) {
      std::fprintf(stderr, "%s: frame %d: %s\n", prog.c_str(), n, s.error().message.c_str());
      return 1;
    }
    timings.add(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count(),
                game.world());
  }
  if ((*device)->validation_messages() > 0) {
    std::fprintf(stderr, "%s: %u validation messages, the last: %s\n", prog.c_str(), (*device)->validation_messages(),
                 (*device)->last_validation_message().c_str());
    return 1;
  }
  if (!options.screenshot.empty()) std::printf("%s: wrote %s\n", prog.c_str(), options.screenshot.c_str());
  timings.print(stdout, prog, options.width, options.height);
  return 0;
}

Result<std::uint32_t> parse_size(std::string_view option, const char* value) {
  char* end = nullptr;
  const long v = std::strtol(value, &end, 10);
  if (end == value || *end != '\0' || v < 16 || v > 8192)
    return make_error(ErrorCode::InvalidArgument, std::string(option) + " takes a size in pixels from 16 to 8192, not '" +
                                                      value + "'");
  return static_cast<std::uint32_t>(v);
}

}  // namespace

void print_usage(std::FILE* out, std::string_view program, std::string_view about) {
  const std::string p(program);
  std::fprintf(out,
               "%.*s\n"
               "usage: %s [--character FILE.glb] [--characters N] [--bake CACHE.pbake] [--preset draft|medium|high]\n"
               "       %*s [--autoplay] [--frames N] [--screenshot F.png] [--width W] [--height H] [--headless]\n"
               "       %*s [--report F.txt] [--stats] [--validation]\n",
               static_cast<int>(about.size()), about.data(), p.c_str(), static_cast<int>(p.size()), "",
               static_cast<int>(p.size()), "");
}

Result<Options> parse_options(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    const bool has_value = i + 1 < argc;
    const auto need = [&](std::string_view what) {
      return make_error(ErrorCode::InvalidArgument, std::string(a) + " takes " + std::string(what));
    };
    if (a == "--autoplay") {
      o.autoplay = true;
    } else if (a == "--headless") {
      o.headless = true;
    } else if (a == "--stats") {
      o.stats = true;
    } else if (a == "--validation") {
      o.validation = true;
    } else if (a == "--frames" || a == "--characters") {
      if (!has_value) return need("a count");
      char* end = nullptr;
      const long v = std::strtol(argv[++i], &end, 10);
      const long lo = 1, hi = a == "--frames" ? 1000000 : 200;
      if (end == argv[i] || *end != '\0' || v < lo || v > hi)
        return make_error(ErrorCode::InvalidArgument, std::string(a) + " takes a count from " + std::to_string(lo) +
                                                          " to " + std::to_string(hi) + ", not '" + argv[i] + "'");
      (a == "--frames" ? o.frames : o.characters) = static_cast<int>(v);
    } else if (a == "--width" || a == "--height") {
      if (!has_value) return need("a size in pixels");
      auto v = parse_size(a, argv[++i]);
      if (!v) return v.error();
      (a == "--width" ? o.width : o.height) = *v;
    } else if (a == "--screenshot" || a == "--report" || a == "--character" || a == "--bake") {
      if (!has_value) return need("a path");
      std::string& field = a == "--screenshot" ? o.screenshot : a == "--report" ? o.report
                                                              : a == "--character" ? o.character : o.bake;
      field = argv[++i];
    } else if (a == "--preset") {
      if (!has_value) return need("draft, medium or high");
      const auto preset = parse_preset(argv[++i]);
      if (!preset) return make_error(ErrorCode::InvalidArgument, "--preset takes draft, medium or high, not '" +
                                                                     std::string(argv[i]) + "'");
      o.preset = *preset;
    } else {
      return make_error(ErrorCode::InvalidArgument, "unknown option '" + std::string(a) + "'");
    }
  }
  if (!has_display() && !o.headless) o.headless = true;
  if (o.headless && o.frames == 0)
    return make_error(ErrorCode::InvalidArgument,
                      "headless runs (--headless, or no display) need --frames N: the number of frames to play");
  return o;
}

int run(std::string_view program, Game& game, const Options& options) {
  std::FILE* report = nullptr;
  if (!options.report.empty()) {
    report = std::fopen(options.report.c_str(), "w");
    if (!report) {
      std::fprintf(stderr, "%.*s: cannot write the report '%s': %s\n", static_cast<int>(program.size()),
                   program.data(), options.report.c_str(), std::strerror(errno));
      return 1;
    }
  }
  const int code = options.headless ? run_headless(program, game, options, report)
                                    : run_windowed(program, game, options, report);
  if (report && std::fclose(report) != 0 && code == 0) {
    std::fprintf(stderr, "%.*s: writing the report '%s' failed\n", static_cast<int>(program.size()), program.data(),
                 options.report.c_str());
    return 1;
  }
  return code;
}

namespace {

// The yaw of the direction a humanoid model faces (0: +Z, the glTF convention), from its posed
// vertices: the toes stick out in front of the shins, so the centroid of the lowest 4% of the
// height lies forward of the centroid at 10-20%. +Z when the feet give no clear answer.
float model_facing(World& world, Entity root) {
  update_world_transforms(world);
  update_skin_poses(world);
  std::vector<glm::vec3> points, skinned;
  world.each<const Mesh, const SkinPose, const WorldTransform>(
      [&](Entity e, const Mesh& mesh, const SkinPose& pose, const WorldTransform& wt) {
        for (Entity up = e; up; up = world.has<Parent>(up) ? world.get<Parent>(up).entity : Entity::null())
          if (up == root) {
            skin_positions(*mesh.data, pose, skinned);
            for (const glm::vec3& p : skinned) points.push_back(glm::vec3(wt.matrix * glm::vec4(p, 1.0f)));
            return;
          }
      });
  if (points.empty()) return 0.0f;
  float lo = points[0].y, hi = points[0].y;
  for (const glm::vec3& p : points) lo = std::min(lo, p.y), hi = std::max(hi, p.y);
  const float h = hi - lo;
  glm::vec2 feet(0.0f), shins(0.0f);
  int nf = 0, ns = 0;
  for (const glm::vec3& p : points) {
    const float f = (p.y - lo) / std::max(h, 1e-6f);
    if (f < 0.04f) feet += glm::vec2(p.x, p.z), ++nf;
    else if (f > 0.10f && f < 0.20f) shins += glm::vec2(p.x, p.z), ++ns;
  }
  if (nf == 0 || ns == 0) return 0.0f;
  const glm::vec2 forward = feet / static_cast<float>(nf) - shins / static_cast<float>(ns);
  if (glm::length(forward) < 0.01f * h) return 0.0f;
  return std::atan2(forward.x, forward.y);
}

}  // namespace

Result<Character> add_character(World& world, const std::string& path, const std::string& name, glm::vec3 position) {
  Character c;
  c.position = position;
  Transform at;
  at.translation = position;
  if (path.empty()) {
    c.root = add_builtin_character(world, Entity::null(), at, name);
    return c;
  }
  ImportOptions options;
  auto result = import_gltf(world, path, options);
  if (!result) return result.error();
  const ImportedScene& imported = *result;
  c.root = imported.root;
  const Animator* animator = world.try_get<Animator>(c.root);
  if (imported.skins == 0 || !animator || !animator->clips || animator->clips->empty()) {
    destroy_hierarchy(world, c.root);
    return make_error(ErrorCode::InvalidInput, path + ": a character needs a skinned mesh and an animation clip (it has " +
                                                   std::to_string(imported.skins) + " skins, " +
                                                   std::to_string(imported.animations) +
                                                   " animations); export it with its walk clip, or leave out "
                                                   "--character for the built-in walker");
  }
  world.add<EntityKey>(c.root, EntityKey{name});
  world.add<Transform>(c.root, at);
  c.facing_offset = -model_facing(world, c.root);
  return c;
}

Obstacles Obstacles::of_static_meshes(World& world) {
  Obstacles o;
  world.each<const Mesh, const WorldTransform, const Static>([&o](const Mesh& mesh, const WorldTransform& wt,
                                                                   const Static&) {
    const MeshData& m = *mesh.data;
    for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      glm::vec3 p[3];
      Aabb box;
      for (int k = 0; k < 3; ++k) {
        p[k] = glm::vec3(wt.matrix * glm::vec4(m.positions[m.indices[t + static_cast<std::size_t>(k)]], 1.0f));
        box.extend(p[k]);
      }
      // Walls: faces steeper than 60 degrees that a walker's body (0.3 to 1.5 m) would hit.
      const glm::vec3 n = glm::cross(p[1] - p[0], p[2] - p[0]);
      const float len = glm::length(n);
      if (len <= 0.0f || std::abs(n.y) / len > 0.5f || box.min.y > 1.5f || box.max.y < 0.3f) continue;
      o.boxes.push_back({{box.min.x, box.min.z}, {box.max.x, box.max.z}});
    }
  });
  return o;
}

bool Obstacles::blocked(glm::vec2 p, float radius) const {
  for (const Box& b : boxes)
    if (glm::distance(p, glm::clamp(p, b.min, b.max)) < radius) return true;
  return false;
}

glm::vec2 Obstacles::resolve(glm::vec2 p, float radius) const {
  for (int pass = 0; pass < 3; ++pass) {
    for (const Box& b : boxes) {
      const glm::vec2 nearest = glm::clamp(p, b.min, b.max);
      const glm::vec2 d = p - nearest;
      const float dist = glm::length(d);
      if (dist >= radius) continue;
      if (dist > 1e-6f) {
        p = nearest + d * (radius / dist);
      } else {  // the centre is inside: leave by the nearest side
        const float left = p.x - b.min.x, right = b.max.x - p.x, down = p.y - b.min.y, up = b.max.y - p.y;
        const float m = std::min({left, right, down, up});
        if (m == left) p.x = b.min.x - radius;
        else if (m == right) p.x = b.max.x + radius;
        else if (m == down) p.y = b.min.y - radius;
        else p.y = b.max.y + radius;
      }
    }
  }
  return p;
}

void walk(World& world, Character& c, glm::vec2 direction, double dt, const Obstacles& obstacles) {
  const float amount = std::min(glm::length(direction), 1.0f);
  const bool moving = amount > 1e-3f;
  if (moving) {
    const glm::vec2 d = direction / glm::length(direction);
    const glm::vec2 next = glm::vec2(c.position.x, c.position.z) + d * (amount * c.speed * static_cast<float>(dt));
    const glm::vec2 p = obstacles.resolve(next, c.radius);
    c.position.x = p.x;
    c.position.z = p.y;
    c.heading = std::atan2(d.x, d.y);
  }
  place(world, c);
  if (Animator* a = world.try_get<Animator>(c.root)) {
    a->playing = moving;
    a->speed = std::max(amount, 0.2f);
  }
}

void place(World& world, const Character& c) {
  const glm::quat rotation = glm::angleAxis(c.heading + c.facing_offset, glm::vec3(0.0f, 1.0f, 0.0f));
  const Transform& now = world.get<Transform>(c.root);
  if (now.translation == c.position && now.rotation == rotation) return;  // unchanged: no change tick
  Transform& t = world.patch<Transform>(c.root);
  t.translation = c.position;
  t.rotation = rotation;
}

CameraView FollowCamera::view(glm::vec3 target, float aspect, const Obstacles& walls) const {
  const glm::vec3 back(-std::sin(yaw_), 0.0f, -std::cos(yaw_));
  // Pulled in front of the first wall between the target and where the camera would be.
  float distance = distance_;
  for (float d = 0.1f; d < distance_; d += 0.05f) {
    if (walls.blocked(glm::vec2(target.x + d * back.x, target.z + d * back.z), 0.15f)) {
      distance = std::max(d - 0.05f, 0.3f);
      break;
    }
  }
  const glm::vec3 eye = target + distance * back + glm::vec3(0.0f, height_ * distance / distance_, 0.0f);
  return look_at_view(eye, target, 1.0f, aspect, 0.05f, 200.0f);
}

glm::vec2 FollowCamera::world_direction(glm::vec2 move) const {
  const glm::vec2 forward(std::sin(yaw_), std::cos(yaw_));
  const glm::vec2 right(-forward.y, forward.x);
  return move.y * forward - move.x * right;
}

Result<std::string> bake_or_load(World& world, Preset preset, const std::string& cache) {
  BakeSettings settings;
  settings.preset = preset;
  const std::uint64_t hash = bake_input_hash(world, {}, settings);
  std::string stale;
  if (!cache.empty() && std::filesystem::exists(cache)) {
    auto file = read_bake_file(cache);
    if (file && file->input_hash == hash) {
      PENUMBRA_TRY(attach_bake(world, *file));
      return "lighting from " + cache + " (current)";
    }
    stale = file ? " (" + cache + " was baked from other inputs)" : " (" + cache + ": " + file.error().message + ")";
  }
  ThreadPool pool;
  int last_stage = 0;
  JobContext jobs(&pool, [&last_stage](const Progress& p) {
    if (p.stage_index != last_stage) {
      std::printf("  baking: %.*s\n", static_cast<int>(p.stage.size()),
                  p.stage.data());
      last_stage = p.stage_index;
    }
  });
  const auto start = std::chrono::steady_clock::now();
  auto result = bake_world(world, {}, settings, jobs);
  if (!result) return result.error();
  const BakeResult& baked = *result;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  char line[160];
  std::snprintf(line, sizeof line, "baked %zu chunks in %.1f s (%s preset)%s", baked.file.chunks.size(), seconds,
                to_string(preset), stale.c_str());
  if (!cache.empty()) {
    PENUMBRA_TRY(write_bake_file(cache, baked.file));
    return std::string(line) + ", written to " + cache;
  }
  return std::string(line);
}

}  // namespace sample
