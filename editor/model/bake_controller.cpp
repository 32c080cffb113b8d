// Background bakes over a World snapshot (bake_controller.h).
#include "bake_controller.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>

#include "fields.h"
#include "load_world.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/entity_key.h"

namespace penumbra::editor {

namespace {

template <class C>
void copy_component(World& from, World& to, Entity src, Entity dst) {
  if (const C* c = from.try_get<C>(src)) to.add<C>(dst, *c);
}

// A World with the same entity indices as `src` holding what the bakers read. Lighting components
// are copied for every entity, or only for `only` when it is not empty.
std::unique_ptr<World> snapshot(World& src, const std::vector<Entity>& only) {
  auto dst = std::make_unique<World>();
  cli::register_modules(*dst);
  // Recreate the index space: create up to the highest live index, then free the gaps.
  std::vector<Entity> live;
  src.view<WorldTransform>().each([&](Entity e, WorldTransform&) { live.push_back(e); });
  src.view<Mesh>().each([&](Entity e, Mesh&) { live.push_back(e); });
  src.view<Light>().each([&](Entity e, Light&) { live.push_back(e); });
  std::uint32_t count = 0;
  for (Entity e : live) count = std::max(count, e.index + 1);
  std::vector<Entity> made(count);
  std::vector<bool> keep(count, false);
  for (Entity e : live) keep[e.index] = true;
  for (std::uint32_t i = 0; i < count; ++i) made[i] = dst->create();
  for (std::uint32_t i = 0; i < count; ++i)
    if (!keep[i]) dst->destroy(made[i]);

  const auto selected = [&](Entity e) {
    return only.empty() || std::find(only.begin(), only.end(), e) != only.end();
  };
  // Components that name entities (skins, the hierarchy, clip targets) get the snapshot's handles:
  // same index, but the generations of the two Worlds differ once entities were destroyed.
  const auto remap = [&](Entity e) {
    return src.alive(e) && e.index < count && keep[e.index] ? made[e.index] : Entity::null();
  };
  std::vector<std::pair<const std::vector<AnimationClip>*, std::shared_ptr<const std::vector<AnimationClip>>>> clips;
  const auto remap_clips = [&](const std::shared_ptr<const std::vector<AnimationClip>>& from) {
    if (!from) return from;
    for (const auto& [key, copy] : clips)
      if (key == from.get()) return copy;
    auto copy = std::make_shared<std::vector<AnimationClip>>(*from);
    for (AnimationClip& clip : *copy)
      for (Entity& target : clip.targets) target = remap(target);
    clips.emplace_back(from.get(), copy);
    return std::shared_ptr<const std::vector<AnimationClip>>(std::move(copy));
  };
  for (std::uint32_t i = 0; i < count; ++i) {
    if (!keep[i]) continue;
    const Entity s = src.handle(i);
    const Entity d = made[i];
    copy_component<Transform>(src, *dst, s, d);
    copy_component<WorldTransform>(src, *dst, s, d);
    copy_component<Mesh>(src, *dst, s, d);
    copy_component<Material>(src, *dst, s, d);
    copy_component<Light>(src, *dst, s, d);
    copy_component<DynamicLight>(src, *dst, s, d);  // a bake of fixed lighting leaves enabled ones out
    copy_component<Environment>(src, *dst, s, d);   // the sky every escaping ray brings
    copy_component<Static>(src, *dst, s, d);
    copy_component<Name>(src, *dst, s, d);
    // The source's key, so that the chunks name the document's entities (scene/entity_key.h).
    if (std::string key = entity_key(src, s); !key.empty()) dst->add<EntityKey>(d, EntityKey{std::move(key)});
    if (const Parent* p = src.try_get<Parent>(s)) dst->add<Parent>(d, Parent{remap(p->entity)});
    if (const Animator* a = src.try_get<Animator>(s)) {
      Animator copy = *a;
      copy.clips = remap_clips(a->clips);
      dst->add<Animator>(d, std::move(copy));
    }
    if (const Skin* skin = src.try_get<Skin>(s)) {
      Skin copy = *skin;
      for (Entity& j : copy.joints) j = remap(j);
      dst->add<Skin>(d, std::move(copy));
    }
    if (selected(s))
      for (const LightingModule* m : lighting_modules())
        for (const ComponentInfo* c : m->components) c->copy(src, s, *dst, d);
  }
  return dst;
}

}  // namespace

const char* to_string(BakeStatus::State state) {
  switch (state) {
    case BakeStatus::State::Idle: return "idle";
    case BakeStatus::State::Running: return "running";
    case BakeStatus::State::Done: return "done";
    case BakeStatus::State::Failed: return "failed";
    case BakeStatus::State::Cancelled: return "cancelled";
  }
  return "idle";
}

std::string bakeable_components() {
  std::string out;
  for (const LightingModule* m : lighting_modules())
    for (const ComponentInfo* c : m->components)
      if (c->set_preset_fields != nullptr) out += (out.empty() ? "" : " or ") + std::string(c->name);
  return out;
}

std::vector<std::string> bakers_for(World& world, Entity e) {
  // The modules whose authoring component (the one with presets) the entity has.
  std::vector<std::string> names;
  for (const LightingModule* m : lighting_modules())
    for (const ComponentInfo* c : m->components)
      if (c->set_preset_fields != nullptr && c->present(world, e)) {
        names.emplace_back(m->name);
        break;
      }
  return names;
}

BakeController::~BakeController() {
  cancel();
  join();
}

Status BakeController::start(Document& doc, const BakeRequest& request) {
  if (running())
    return make_error(ErrorCode::InvalidArgument, "a bake is already running; cancel it or wait for it to finish");
  join();  // a finished worker that poll() has not collected: its outcome is dropped
  World& world = doc.world();
  for (Entity e : request.entities)
    if (!world.alive(e))
      return make_error(ErrorCode::InvalidArgument, "bake: entity #" + std::to_string(e.index) +
                                                        " no longer exists; select the entities again");
  const auto& registry = world.resource<BakerRegistry>();
  for (const std::string& name : request.bakers)
    if (registry.find(name) == nullptr) {
      std::string known;
      for (const Baker& b : registry.all()) known += (known.empty() ? "" : ", ") + b.name;
      return make_error(ErrorCode::NotFound, "bake: no baker named '" + name + "'; known bakers: " + known);
    }
  if (!request.entities.empty() && request.bakers.empty())
    return make_error(ErrorCode::InvalidArgument,
                      "bake selection: the selected entities have no lighting component to bake; select an entity "
                      "with " + bakeable_components());

  std::shared_ptr<World> snap = snapshot(world, request.entities);
  if (request.component_preset)
    for (const ComponentPreset& p : component_presets())
      for (std::uint32_t i = 0, seen = 0; seen < snap->entity_count(); ++i)
        if (const Entity e = snap->find_entity(i)) {
          ++seen;
          if (p.present(*snap, e)) p.apply(*snap, e, *request.component_preset);
        }
  if (!request.estimate && request.keep)
    inputs_ = doc.bake_tracker().begin(world, request.bakers, request.entities, request.settings);
  {
    std::lock_guard lock(mutex_);
    status_ = BakeStatus{};
    status_.state = BakeStatus::State::Running;
    status_.estimating = request.estimate;
    status_.kept = request.keep && !request.estimate;
    finished_ = false;
  }
  cancel_ = std::make_unique<CancelToken>();
  document_ = &doc;
  started_ = std::chrono::steady_clock::now();
  worker_ = std::thread([this, snap, request, cancel = cancel_.get()] {
    // Lower this thread's priority; the pool's threads inherit it.
    if (request.low_priority) setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), 10);
    ThreadPool pool(request.threads);
    JobContext jobs(&pool, [this](const Progress& p) {
      std::lock_guard lock(mutex_);
      status_.stage_count = p.stage_count;
      const auto i = static_cast<std::size_t>(std::max(p.stage_index, 1) - 1);
      if (status_.stages.size() <= i) status_.stages.resize(i + 1);
      status_.stages[i].name = std::string(p.stage);
      status_.stages[i].fraction = p.fraction;
    }, cancel);
    if (request.estimate) {
      Result<BakeEstimate> estimate = estimate_bake(*snap, request.bakers, request.settings, jobs);
      std::lock_guard lock(mutex_);
      estimate_outcome_.emplace(std::move(estimate));
    } else {
      Result<BakeResult> outcome = bake_world(*snap, request.bakers, request.settings, jobs);
      std::lock_guard lock(mutex_);
      outcome_.emplace(std::move(outcome));
    }
    std::lock_guard lock(mutex_);
    finished_ = true;
  });
  return {};
}

void BakeController::cancel() {
  if (cancel_) cancel_->cancel();
}

bool BakeController::running() const {
  std::lock_guard lock(mutex_);
  return worker_.joinable() && !finished_;
}

void BakeController::join() {
  if (worker_.joinable()) worker_.join();
}

void BakeController::wait() { join(); }

bool BakeController::poll(Document& doc) {
  {
    std::lock_guard lock(mutex_);
    if (!finished_ || (!outcome_ && !estimate_outcome_)) {
      if (status_.state == BakeStatus::State::Running)
        status_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
      return false;
    }
  }
  join();
  std::optional<Result<BakeResult>> outcome;
  std::optional<Result<BakeEstimate>> estimate;
  {
    std::lock_guard lock(mutex_);
    outcome.swap(outcome_);
    estimate.swap(estimate_outcome_);
  }
  BakeStatus next = status();
  next.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  if (estimate) {
    if (estimate->ok()) {
      next.state = BakeStatus::State::Done;
      next.estimate = std::move(estimate->value());
    } else {
      next.state = estimate->error().code == ErrorCode::Cancelled ? BakeStatus::State::Cancelled : BakeStatus::State::Failed;
      next.error = estimate->error().message;
    }
  } else if (!outcome->ok()) {
    const Error& e = outcome->error();
    next.state = e.code == ErrorCode::Cancelled ? BakeStatus::State::Cancelled : BakeStatus::State::Failed;
    next.error = e.message;
  } else if (&doc != document_) {
    next.state = BakeStatus::State::Failed;
    next.error = "the document was replaced while baking; bake again";
  } else {
    BakeResult& r = outcome->value();
    next.report = r.report;
    for (const BakeChunk& c : r.file.chunks) next.bytes += c.payload.size();
    // Swap the results in: the lighting systems and the renderer pick the patched components up.
    if (!next.kept) {
      next.state = BakeStatus::State::Done;  // measured only
    } else if (Status s = doc.attach(std::move(r.file)); !s) {
      next.state = BakeStatus::State::Failed;
      next.error = "the bake finished but its results do not fit the scene any more (" + s.error().message + ")";
    } else {
      next.state = BakeStatus::State::Done;
      doc.bake_tracker().commit(std::move(inputs_), r.report);
    }
  }
  std::lock_guard lock(mutex_);
  status_ = std::move(next);
  return true;
}

BakeStatus BakeController::status() const {
  std::lock_guard lock(mutex_);
  return status_;
}

}  // namespace penumbra::editor
