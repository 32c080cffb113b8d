// World: entity slots, the type-independent half of the sparse-set pools, systems and events.
// Layout and semantics are documented in penumbra/ecs/world.h.
#include "penumbra/ecs/world.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <mutex>
#include <stdexcept>

#ifdef __linux__
#include <sys/mman.h>
#endif

namespace penumbra {

namespace {

struct ComponentRegistry {
  std::mutex mutex;
  std::deque<std::string> names;  // deque: names handed out as string_views never move
};

ComponentRegistry& registry() {
  static ComponentRegistry r;
  return r;
}

// "... [with T = penumbra::Transform; std::string_view = ...]" -> "Transform".
std::string type_name_from_signature(std::string_view signature) {
  const std::size_t begin = signature.find("T = ");
  if (begin == std::string_view::npos) return std::string(signature);
  std::string_view name = signature.substr(begin + 4);
  name = name.substr(0, std::min(name.find(';'), name.rfind(']')));
  constexpr std::string_view kOurs = "penumbra::";
  if (name.substr(0, kOurs.size()) == kOurs) name.remove_prefix(kOurs.size());
  return std::string(name);
}

}  // namespace

namespace detail {

constexpr std::size_t kHugePage = std::size_t{2} << 20;

ComponentId register_component(std::string_view signature) {
  ComponentRegistry& r = registry();
  std::lock_guard lock(r.mutex);
  r.names.push_back(type_name_from_signature(signature));
  return static_cast<ComponentId>(r.names.size() - 1);
}

void* allocate_block(std::size_t bytes, std::size_t align) {
  const bool huge = bytes >= kHugePage;
  if (huge) align = std::max(align, kHugePage);
  const std::size_t size = (bytes + align - 1) / align * align;  // aligned_alloc wants a multiple
  void* block = std::aligned_alloc(align, size);
  if (!block) throw std::bad_alloc();
#ifdef __linux__
  if (huge) madvise(block, size, MADV_HUGEPAGE);  // advice only: failure is harmless
#endif
  return block;
}

void BlockDeleter::operator()(void* block) const { std::free(block); }

void* zeroed_grow(void* data, std::size_t& bytes, std::size_t wanted) {
  // calloc: fresh pages from the OS come zeroed without being touched here.
  void* grown = std::calloc(wanted, 1);
  if (!grown) throw std::bad_alloc();
  if (data) {
    std::memcpy(grown, data, bytes);
    std::free(data);
  }
  bytes = wanted;
  return grown;
}

void zeroed_free(void* data) { std::free(data); }

#ifdef __linux__
namespace {

// Regions released by pools, kept for the next pool as the heap keeps freed blocks: their
// committed pages are already faulted in, so filling a new World does not pay for fresh memory
// again. At most kCachedBytes committed in all; never destroyed, so pools of static Worlds may
// release into it at exit.
struct RegionCache {
  struct Entry {
    void* mapping;
    std::size_t mapping_bytes;
    std::byte* base;
    std::size_t committed;
  };
  static constexpr std::size_t kCachedBytes = std::size_t{64} << 20;
  std::mutex mutex;
  std::vector<Entry> entries;
  std::size_t committed = 0;
};

RegionCache& region_cache() {
  static RegionCache* cache = new RegionCache;
  return *cache;
}

}  // namespace
#endif

namespace {
std::atomic<bool> regions_enabled{true};
}  // namespace

void Region::enable(bool on) { regions_enabled.store(on, std::memory_order_relaxed); }

Region::~Region() {
#ifdef __linux__
  if (!mapping_) return;
  RegionCache& cache = region_cache();
  {
    std::lock_guard lock(cache.mutex);
    if (cache.committed + committed_ <= RegionCache::kCachedBytes) {
      cache.entries.push_back({mapping_, mapping_bytes_, base_, committed_});
      cache.committed += committed_;
      return;
    }
  }
  munmap(mapping_, mapping_bytes_);
#endif
}

bool Region::reserve() {
#ifdef __linux__
  if (mapping_ || sizeof(void*) < 8 || !regions_enabled.load(std::memory_order_relaxed)) return false;
  RegionCache& cache = region_cache();
  {
    std::lock_guard lock(cache.mutex);
    if (!cache.entries.empty()) {
      const RegionCache::Entry e = cache.entries.back();
      cache.entries.pop_back();
      cache.committed -= e.committed;
      mapping_ = e.mapping;
      mapping_bytes_ = e.mapping_bytes;
      base_ = e.base;
      committed_ = e.committed;
      return true;
    }
  }
  // PROT_NONE and MAP_NORESERVE: address space only, no commit charge until commit(). One huge
  // page more than asked, to align the start.
  const std::size_t size = kRegionBytes + kHugePage;
  void* mapping = mmap(nullptr, size, PROT_NONE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
  if (mapping == MAP_FAILED) return false;
  mapping_ = mapping;
  mapping_bytes_ = size;
  const auto start = reinterpret_cast<std::uintptr_t>(mapping);
  base_ = reinterpret_cast<std::byte*>((start + kHugePage - 1) / kHugePage * kHugePage);
  madvise(base_, kRegionBytes, MADV_HUGEPAGE);  // advice only
  return true;
#else
  return false;
#endif
}

void Region::commit(std::size_t bytes) {
#ifdef __linux__
  constexpr std::size_t kOsPage = 4096;
  const std::size_t size = (bytes + kOsPage - 1) / kOsPage * kOsPage;
  if (size <= committed_) return;
  if (mprotect(base_ + committed_, size - committed_, PROT_READ | PROT_WRITE) != 0) throw std::bad_alloc();
  committed_ = size;
#else
  (void)bytes;
#endif
}

// --- PoolBase ----------------------------------------------------------------------------------

void PoolBase::grow() {
  // Blocks grow geometrically, as for the components (Pool::emplace).
  const std::size_t count = index_pages_.empty() ? 1 : index_pages_.size();
  auto* indices = static_cast<std::uint32_t*>(allocate_block(sizeof(std::uint32_t) * kPageSize * count, 64));
  blocks_.emplace_back(indices);
  auto* ticks = static_cast<std::uint64_t*>(allocate_block(sizeof(std::uint64_t) * kPageSize * count, 64));
  blocks_.emplace_back(ticks);
  for (std::size_t i = 0; i < count; ++i) {
    index_pages_.push_back(indices + i * kPageSize);
    tick_pages_.push_back(ticks + i * kPageSize);
  }
}

void PoolBase::put(std::uint32_t entity_index, std::uint32_t& entry, std::uint64_t tick_value) {
  const std::uint32_t pos = entity_index;
  if (pos < size_) {
    ++layout_version_;  // a hole takes an entity
    --tombstones_;
  } else {
    for (std::uint32_t hole = size_; hole < pos; ++hole) index(hole) = kNone;
    tombstones_ += pos - size_;
    size_ = pos + 1;
  }
  entry = pos + 1;
  index(pos) = entity_index;
  tick(pos) = tick_value;
}

bool PoolBase::vacate(std::uint32_t pos, std::uint32_t removed, bool iterating) {
  ++layout_version_;
  sparse_[removed] = 0;
  index(pos) = kNone;
  ++tombstones_;
  if (iterating) return pos + 1 == size_;  // a running iteration has taken size() already
  drop_trailing_holes();
  return false;
}

void PoolBase::drop_trailing_holes() {
  while (size_ > 0 && index(size_ - 1) == kNone) {
    --size_;
    --tombstones_;
  }
}

bool PoolBase::erase(std::uint32_t pos, bool iterating) {
  if (indexed_) {
    const std::uint32_t removed = index(pos);
    destroy_at(pos);
    return vacate(pos, removed, iterating);
  }
  if (iterating) {
    // Leave a tombstone: positions the running iteration has not reached must not move.
    const std::uint32_t removed = index(pos);
    ++layout_version_;
    sparse_[removed] = 0;
    destroy_at(pos);
    index(pos) = kNone;
    ++tombstones_;
    return true;
  }
  // Swap-and-pop: the last component moves into the hole.
  const std::uint32_t last = pop_slot(pos, index(pos));
  if (pos != last)
    move_last_into(pos, last);
  else
    destroy_at(pos);
  return false;
}

void PoolBase::compact() {
  compact_pending_ = false;
  if (indexed_) {  // slots are fixed by entity index: only the tail goes
    drop_trailing_holes();
    return;
  }
  ++layout_version_;
  std::uint32_t out = 0;
  for (std::uint32_t i = 0; i < size_; ++i) {
    if (index(i) == kNone) continue;
    if (i != out) {
      relocate(i, out);
      index(out) = index(i);
      tick(out) = tick(i);
      sparse_[index(out)] = out + 1;
    }
    ++out;
  }
  size_ = out;
  tombstones_ = 0;
}

void PoolBase::swap_slots(std::uint32_t a, std::uint32_t b) {
  ++layout_version_;
  swap_components(a, b);
  std::swap(index(a), index(b));
  std::swap(tick(a), tick(b));
  sparse_[index(a)] = a + 1;
  sparse_[index(b)] = b + 1;
}

void PoolBase::reserve(std::uint32_t count) {
  while (index_pages_.size() * kPageSize < count) grow();
  const std::size_t slots = std::min<std::size_t>(index_pages_.size() * kPageSize, kNone);
  capacity_ = std::min(static_cast<std::uint32_t>(slots), reserve_components(count));
}

void PoolBase::fire(World& world, std::vector<std::shared_ptr<Listener>>& listeners, Entity e) {
  struct Firing {
    PoolBase& p;
    explicit Firing(PoolBase& pool) : p(pool) { ++p.firing_; }
    ~Firing() { --p.firing_; }
    Firing(const Firing&) = delete;
    Firing& operator=(const Firing&) = delete;
  };
  {
    Firing firing(*this);
    // Index loop and a held reference: listeners may connect others (the vector may grow).
    for (std::size_t i = 0; i < listeners.size(); ++i) {
      const std::shared_ptr<Listener> l = listeners[i];
      if (l->connected) l->fn(world, e);
    }
  }
  prune_listeners();
}

void PoolBase::prune_listeners() {
  if (firing_ != 0) return;
  const auto disconnected = [](const std::shared_ptr<Listener>& l) { return !l->connected; };
  std::erase_if(on_add_, disconnected);
  std::erase_if(on_remove_, disconnected);
  refresh_plain_pop();
}

// --- GroupBase ---------------------------------------------------------------------------------

bool GroupBase::qualifies(std::uint32_t index) const {
  const auto has = [index](const PoolBase* p) { return p->find(index) != kNone; };
  return std::all_of(owned.begin(), owned.end(), has) && std::all_of(observed.begin(), observed.end(), has);
}

void GroupBase::enter(std::uint32_t index) {
  for (PoolBase* p : owned) {
    const std::uint32_t pos = p->find(index);
    if (pos != size) p->swap_slots(pos, size);
  }
  ++size;
}

void GroupBase::leave(std::uint32_t index) {
  --size;
  for (PoolBase* p : owned) {
    const std::uint32_t pos = p->find(index);
    if (pos != size) p->swap_slots(pos, size);
  }
}

void GroupBase::repack() {
  // Slots [0, size) of the first owned pool hold the members found so far and [size, i) the
  // non-members passed over, so swapping slot i into slot size keeps both runs intact.
  size = 0;
  dirty = false;
  const PoolBase& first = *owned[0];
  for (std::uint32_t i = 0; i < first.size(); ++i) {
    const std::uint32_t index = first.index(i);
    if (qualifies(index)) enter(index);
  }
}

}  // namespace detail

std::string_view component_name(ComponentId id) {
  ComponentRegistry& r = registry();
  std::lock_guard lock(r.mutex);
  return id < r.names.size() ? std::string_view(r.names[id]) : std::string_view();
}

const char* to_string(Phase phase) {
  switch (phase) {
    case Phase::Input: return "input";
    case Phase::Animation: return "animation";
    case Phase::Transform: return "transform";
    case Phase::Lighting: return "lighting";
    case Phase::Render: return "render";
  }
  return "unknown";
}

// --- World -------------------------------------------------------------------------------------

World::World() = default;
World::~World() = default;
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;

Entity World::create() {
  ++entities_.alive;
  if (entities_.free_head != detail::kNone) {
    const std::uint32_t index = entities_.free_head;
    std::uint64_t& link = masks_[std::size_t{index} * mask_words_];
    entities_.free_head = static_cast<std::uint32_t>(link);
    link = 0;
    slots_[index] &= ~kDeadBit;
    return Entity{index, slots_[index]};
  }
  const auto index = static_cast<std::uint32_t>(slots_.size());
  assert(index != detail::kNone && "World::create: 2^32 - 1 entity slots in use");
  slots_.push_back(0);
  if (std::size_t{index} * mask_words_ >= masks_.size()) add_mask_rows();
  return Entity{index, 0};
}

void World::add_mask_rows() {
  // As many rows as the entity slots have room for: they grow together, geometrically.
  masks_.grow(std::max<std::size_t>(slots_.capacity(), 64) * mask_words_);
}

void World::create(std::span<Entity> out) {
  const std::size_t free = slots_.size() - entities_.alive - entities_.retired;
  const std::size_t fresh = out.size() > free ? out.size() - free : 0;
  slots_.reserve(slots_.size() + fresh);
  add_mask_rows();
  for (Entity& e : out) e = create();
}

bool World::destroy_components(Entity e) {
  // Remove every component the mask names; repeat in case an on_remove listener added one back.
  // A component whose removal is already under way up the stack reports false and ends the loop.
  for (bool removed = true; removed && alive(e);) {
    removed = false;
    bool left = false;
    for (std::uint32_t word = 0; word < mask_words_ && alive(e); ++word) {
      std::uint64_t bits = masks_[std::size_t{e.index} * mask_words_ + word];
      while (bits != 0 && alive(e)) {
        const auto bit = word * 64u + static_cast<std::uint32_t>(std::countr_zero(bits));
        bits &= bits - 1;
        removed |= remove_from(*by_bit_[bit], e);
      }
      left = left || (alive(e) && masks_[std::size_t{e.index} * mask_words_ + word] != 0);
    }
    removed = removed && left;
  }
  return alive(e);  // false: a listener destroyed it already
}

void World::destroy(std::span<const Entity> entities) {
  for (const Entity e : entities) destroy(e);
}

detail::PoolBase& World::add_pool(ComponentId id, std::unique_ptr<detail::PoolBase> pool) {
  if (id >= pools_.size()) pools_.resize(id + 1);
  pool->id_ = id;
  pool->bit_ = static_cast<std::uint32_t>(by_bit_.size());
  by_bit_.push_back(pool.get());
  if (by_bit_.size() > std::size_t{mask_words_} * 64) {
    // One more mask word per entity: spread the masks out.
    const std::uint32_t words = mask_words_ + 1;
    const std::size_t rows = masks_.size() / mask_words_;
    detail::ZeroedArray<std::uint64_t> masks;
    masks.grow(rows * words);
    for (std::size_t i = 0; i < rows; ++i)
      for (std::uint32_t w = 0; w < mask_words_; ++w) masks[i * words + w] = masks_[i * mask_words_ + w];
    masks_ = std::move(masks);
    mask_words_ = words;
  }
  pools_[id] = std::move(pool);
  return *pools_[id];
}

void World::join_groups(detail::PoolBase& p, std::uint32_t index) {
  for (detail::GroupBase* g : p.groups_) {
    if (g->dirty || !g->qualifies(index)) continue;
    if (iterating_ > 0) {
      g->dirty = true;  // no slot may move under a running iteration
      dirty_groups_.push_back(g);
    } else {
      g->enter(index);
    }
  }
}

void World::leave_groups(detail::PoolBase& p, std::uint32_t index) {
  for (detail::GroupBase* g : p.groups_) {
    if (g->dirty || !g->member(index)) continue;
    if (iterating_ > 0) {
      g->dirty = true;
      dirty_groups_.push_back(g);
    } else {
      g->leave(index);
    }
  }
}

detail::GroupBase& World::make_group(std::vector<detail::PoolBase*> owned, std::vector<detail::PoolBase*> observed) {
  const auto ids = [](const std::vector<detail::PoolBase*>& pools) {
    std::vector<ComponentId> out;
    for (const detail::PoolBase* p : pools) out.push_back(p->id_);
    std::sort(out.begin(), out.end());
    return out;
  };
  const std::vector<ComponentId> owned_ids = ids(owned), observed_ids = ids(observed);
  for (const auto& g : groups_)
    if (ids(g->owned) == owned_ids && ids(g->observed) == observed_ids) return *g;
  for (const detail::PoolBase* p : owned) {
    if (p->indexed_)
      throw std::logic_error("World::group: " + std::string(component_name(p->id_)) +
                             " has indexed storage, whose slots are fixed by entity index, so no group can own it "
                             "(observe it instead)");
    if (!p->owner_) continue;
    std::string names;
    for (const ComponentId id : p->owner_->types) names += (names.empty() ? "" : ", ") + std::string(component_name(id));
    throw std::logic_error("World::group: " + std::string(component_name(p->id_)) +
                           " is already owned by the group of " + names +
                           "; a type is owned by one group at most (observe it instead)");
  }
  std::vector<ComponentId> types = owned_ids;
  types.insert(types.end(), observed_ids.begin(), observed_ids.end());
  std::sort(types.begin(), types.end());
  if (const auto twice = std::adjacent_find(types.begin(), types.end()); twice != types.end())
    throw std::logic_error("World::group: " + std::string(component_name(*twice)) + " is named twice");
  auto g = std::make_unique<detail::GroupBase>();
  g->owned = std::move(owned);
  g->observed = std::move(observed);
  g->types = std::move(types);
  for (detail::PoolBase* p : g->owned) p->owner_ = g.get();
  for (detail::PoolBase* p : g->owned) p->groups_.push_back(g.get());
  for (detail::PoolBase* p : g->observed) p->groups_.push_back(g.get());
  for (detail::PoolBase* p : g->owned) p->refresh_plain_pop();
  for (detail::PoolBase* p : g->observed) p->refresh_plain_pop();
  if (iterating_ > 0) {
    g->dirty = true;
    dirty_groups_.push_back(g.get());
  } else {
    g->repack();
  }
  groups_.push_back(std::move(g));
  return *groups_.back();
}

std::size_t World::copy_components(Entity src, World& to, Entity dst) {
  assert(alive(src) && to.alive(dst) && "World::copy_components: stale or null entity handle");
  assert((&to != this || src != dst) && "World::copy_components: an entity onto itself");
  // The pools first: adding to this World may add pools and widen the masks.
  std::vector<detail::PoolBase*> pools;
  const std::uint64_t* row = &masks_[std::size_t{src.index} * mask_words_];
  for (std::uint32_t word = 0; word < mask_words_; ++word)
    for (std::uint64_t bits = row[word]; bits != 0; bits &= bits - 1)
      pools.push_back(by_bit_[word * 64u + static_cast<std::uint32_t>(std::countr_zero(bits))]);
  std::size_t skipped = 0;
  for (detail::PoolBase* p : pools) {
    const std::uint32_t pos = p->find(src.index);  // again each time: a group may have moved it
    if (pos != detail::kNone && !p->copy_to(pos, to, dst)) ++skipped;
  }
  return skipped;
}

bool World::remove_from(detail::PoolBase& p, Entity e) {
  std::uint32_t pos = p.find(e.index);
  if (pos == detail::kNone) return false;
  if (!p.on_remove_.empty()) {
    const std::pair<const detail::PoolBase*, std::uint32_t> key{&p, e.index};
    if (std::find(removing_.begin(), removing_.end(), key) != removing_.end()) return false;
    removing_.push_back(key);
    p.fire(*this, p.on_remove_, e);
    removing_.erase(std::find(removing_.begin(), removing_.end(), key));
    pos = p.find(e.index);  // a listener may have removed it, or moved it by another removal
    if (pos == detail::kNone) return true;
  }
  if (!p.groups_.empty()) {
    leave_groups(p, e.index);
    pos = p.find(e.index);  // leaving a group moves it
  }
  erase_at(p, e.index, pos);
  return true;
}

void World::erase_at(detail::PoolBase& p, std::uint32_t index, std::uint32_t pos) {
  mask_word(index, p.bit_) &= ~mask_bit(p.bit_);
  if (p.erase(pos, iterating_ > 0) && !p.compact_pending_) {
    p.compact_pending_ = true;
    pending_compaction_.push_back(&p);
  }
}

void World::finish_iteration() {
  for (detail::PoolBase* p : pending_compaction_) p->compact();
  pending_compaction_.clear();
  // Listeners do not run here, so nothing can start another iteration before this ends.
  for (detail::GroupBase* g : dirty_groups_) g->repack();
  dirty_groups_.clear();
}

Connection World::connect(detail::PoolBase& p, std::vector<std::shared_ptr<detail::Listener>>& list,
                          std::function<void(World&, Entity)> fn) {
  p.prune_listeners();
  auto listener = std::make_shared<detail::Listener>();
  listener->fn = std::move(fn);
  list.push_back(listener);
  p.refresh_plain_pop();
  return Connection(listener);
}

bool World::write_declared(ComponentId id) const {
  if (running_system_ < 0) return true;
  const auto& writes = systems_[static_cast<std::size_t>(running_system_)].writes;
  return std::find(writes.begin(), writes.end(), id) != writes.end();
}

void World::add_system(SystemDesc desc) {
  assert(running_system_ < 0 && "World::add_system: not while update() runs");
  // After the last system of the same or an earlier phase.
  const auto at = std::find_if(systems_.begin(), systems_.end(),
                               [&](const SystemInfo& s) { return s.phase > desc.phase; });
  const auto offset = at - systems_.begin();
  SystemInfo info;
  info.name = std::move(desc.name);
  info.phase = desc.phase;
  info.reads = std::move(desc.reads);
  info.writes = std::move(desc.writes);
  systems_.insert(at, std::move(info));
  system_fns_.insert(system_fns_.begin() + offset, std::move(desc.run));
}

void World::run_phase(Phase phase, double dt) {
  for (std::size_t i = 0; i < systems_.size(); ++i) {
    if (systems_[i].phase != phase || !system_fns_[i]) continue;
    SystemContext ctx;
    ctx.dt = dt;
    ctx.last_run = systems_[i].last_run;
    ctx.tick = advance_tick();
    running_system_ = static_cast<int>(i);
    const auto start = std::chrono::steady_clock::now();
    system_fns_[i](*this, ctx);
    const auto stop = std::chrono::steady_clock::now();
    running_system_ = -1;
    systems_[i].last_run = ctx.tick;
    systems_[i].last_ms = std::chrono::duration<double, std::milli>(stop - start).count();
    ++systems_[i].runs;
  }
  advance_tick();
}

void World::update(double dt) {
  for (int phase = 0; phase < kPhaseCount; ++phase) run_phase(static_cast<Phase>(phase), dt);
}

}  // namespace penumbra
