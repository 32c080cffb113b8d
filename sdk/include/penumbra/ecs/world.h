// The entity-component-system World: entities with generation-checked handles, components in
// sparse sets, views, groups, systems run in phases, change ticks, add/remove events and resources.
//
// Storage. Each component type T has one pool, a sparse set: a sparse array (entity index ->
// dense position; one flat array, zero until written) and, per dense position, the entity index,
// the component and its change tick, all three in pages of 1024 (adding a component never moves
// existing ones). The components' pages are committed in a reserved address range (1 GiB per
// pool), so up to that size they are one array and a look-up is two indexed reads: sparse entry,
// then component. Pages beyond it, and the entities' and ticks' pages, come from geometrically
// growing blocks, so consecutive pages are mostly adjacent and iteration streams. Views
// walk the smallest pool and find the others' components at the same position when the pools
// line up (entities given the same components in the same order), else through the sparse array.
// Component ids are process-wide, but a World holds pools only for the types it uses and keeps a
// bit mask per entity of the pools that hold its components, so destroy() visits only those.
//
// Indexed storage. A type declared Storage::Indexed (kComponentStorage below) keeps entity i's
// component at dense position i, so a hoisted get is one indexed read (ComponentPool::get); the
// positions of entities without it are holes that iteration skips like tombstones. Its pool spans
// the largest entity index that has the component (memory and iteration cost by that index, not
// by the count), a removal leaves a hole instead of moving the last component (references stay
// valid until their own component goes), and no group may own it (observing is fine). Views walk
// it in step with other pools only where their slots hold the same entities (no holes, and
// components added in index order); elsewhere they look each component up. Suits types that
// nearly every entity has and that systems look up at random more than they iterate. An entity
// given such a component during an iteration is visited if its index lies ahead of the iteration
// (the rule above holds for Dense types only).
//
// Groups. world.group<A, B>() (or group<A>(observe<B>)) keeps the entities that have every one of
// the group's types packed at the front of each owned pool (A and B in the first form; only A in
// the second, where B is observed), in the same order, updated on every add and remove. A view of exactly the group's types then walks
// those front slots: owned components as plain arrays, observed ones by look-up. A pool is owned
// by at most one group. Members are visited in the owned pools' slot order, which changes as
// entities join (appended) and leave (the last member takes the leaver's slot).
//
// Change ticks. The world has a tick counter (tick()); add() and patch() stamp the component with
// the current tick. The tick advances before each system runs and after each update(), so every
// write is ordered against every system run: a system that keeps its last-run tick sees exactly
// the components written after it last ran (view.each_changed(ctx.last_run, fn)).
//
// Structural changes during iteration (defined behaviour). While a view is iterating, each entity
// that has all the components when iteration starts is visited exactly once unless it loses one
// of them before it is reached; entities that gain them during iteration are not visited.
// Removals during iteration leave a tombstone that is compacted when the outermost iteration ends;
// groups whose membership changed during iteration are repacked then too (until that, views of
// them take the ordinary path).
//
// References. A reference to a component stays valid while other components are added (to any
// pool) and while anything is removed during iteration. A removal outside iteration (including
// the compaction at the end of an iteration with removals) may move other components of that
// pool: fetch again after removing (indexed storage never moves a component). The exception is a
// group's owned pools: outside iteration, adding or removing any of the group's types may move
// their components.
//
// Thread safety: a World is not thread-safe; use it from one thread at a time (systems may fan
// work out to the job system over component references they fetched beforehand).
#pragma once

#include <algorithm>
#include <bit>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <new>
#include <span>
#include <string>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace penumbra {

class World;

// A generation-checked handle: when an entity is destroyed its index's generation is bumped, so an
// old handle is detected as stale (alive() == false) and never aliases a later entity. Generations
// use 31 bits; an index whose generation is exhausted is retired rather than reused.
struct Entity {
  std::uint32_t index = ~0u;
  std::uint32_t generation = 0;

  bool operator==(const Entity&) const = default;
  explicit operator bool() const { return index != ~0u; }  // false for null
  static constexpr Entity null() { return Entity{}; }
};

// A small integer naming a component (or resource) type, process-wide, assigned on first use.
using ComponentId = std::uint32_t;

namespace detail {
ComponentId register_component(std::string_view signature);
template <class T>
constexpr std::string_view type_signature() { return __PRETTY_FUNCTION__; }
template <class T>
ComponentId component_id_of() {
  static const ComponentId id = register_component(type_signature<T>());
  return id;
}
}  // namespace detail

// How a component type's pool stores it (see "Storage" and "Indexed storage" at the top).
enum class Storage : std::uint8_t { Dense, Indexed };
// The storage of component type T: Dense unless specialised, e.g.
//   template <> inline constexpr Storage kComponentStorage<Transform> = Storage::Indexed;
// in namespace penumbra, before T's first use.
template <class T>
inline constexpr Storage kComponentStorage = Storage::Dense;

// The id of component type T (cv-qualifiers ignored). Thread-safe.
template <class T>
ComponentId component_id() { return detail::component_id_of<std::remove_cv_t<T>>(); }

// The type's name, e.g. "Transform" (namespace penumbra:: dropped); "" for an unknown id.
std::string_view component_name(ComponentId id);

// Systems run phase by phase in this order; within a phase in registration order.
enum class Phase : std::uint8_t { Input, Animation, Transform, Lighting, Render };
inline constexpr int kPhaseCount = 5;
const char* to_string(Phase phase);

// What a system receives when it runs.
struct SystemContext {
  double dt = 0.0;              // seconds since the previous update()
  std::uint64_t last_run = 0;   // the tick of this system's previous run; 0 before its first run
  std::uint64_t tick = 0;       // the tick of this run; this system's writes carry it
};

struct SystemDesc {
  std::string name;
  Phase phase = Phase::Input;
  std::vector<ComponentId> reads, writes;  // declared access (component_id<T>())
  std::function<void(World&, const SystemContext&)> run;
};

// A registered system as the editor and tools see it.
struct SystemInfo {
  std::string name;
  Phase phase = Phase::Input;
  std::vector<ComponentId> reads, writes;
  std::uint64_t last_run = 0;  // tick of the last run (0: never ran)
  double last_ms = 0.0;        // wall-clock milliseconds of the last run
  std::uint64_t runs = 0;
};

namespace detail {
struct Listener {
  std::function<void(World&, Entity)> fn;
  bool connected = true;  // cleared by Connection::disconnect(); pruned when no event is firing
};
}  // namespace detail

// Keeps an event listener connected; disconnects it when destroyed (or by disconnect()). Safe to
// destroy after the World is gone. release() leaves the listener connected for the World's life.
class [[nodiscard]] Connection {
 public:
  Connection() = default;
  explicit Connection(std::weak_ptr<detail::Listener> listener) : listener_(std::move(listener)) {}
  Connection(Connection&&) noexcept = default;
  Connection& operator=(Connection&& other) noexcept {
    if (this != &other) {
      disconnect();
      listener_ = std::move(other.listener_);
    }
    return *this;
  }
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;
  ~Connection() { disconnect(); }

  void disconnect() {
    if (auto l = listener_.lock()) l->connected = false;
    listener_.reset();
  }
  void release() { listener_.reset(); }
  bool connected() const {
    auto l = listener_.lock();
    return l && l->connected;
  }

 private:
  std::weak_ptr<detail::Listener> listener_;
};

namespace detail {

inline constexpr std::uint32_t kNone = ~0u;             // no dense position / tombstone index
inline constexpr std::uint32_t kPageShift = 10;          // 1024 components per page
inline constexpr std::uint32_t kPageSize = 1u << kPageShift;

// Raw storage for pool pages, aligned to `align` (a power of two). Blocks of 2 MiB or more ask
// the OS for transparent huge pages (Linux), which cuts the first-touch page faults that dominate
// filling a large new World. Throws std::bad_alloc like operator new.
void* allocate_block(std::size_t bytes, std::size_t align);
struct BlockDeleter {
  void operator()(void* block) const;
};
using Block = std::unique_ptr<void, BlockDeleter>;

class GroupBase;

// Zeroed memory for arrays indexed by entity: growth is one calloc (fresh pages from the OS arrive
// zeroed, untouched) and one memcpy of the `bytes` held. Returns the new start, `bytes` set to
// `wanted`; throws std::bad_alloc.
void* zeroed_grow(void* data, std::size_t& bytes, std::size_t wanted);
void zeroed_free(void* data);

// A growable array of trivial words that are zero until written. Growth (doubling) moves it.
// Moving the array leaves the source empty.
template <class W>
class ZeroedArray {
  static_assert(std::is_trivially_copyable_v<W>);

 public:
  ZeroedArray() = default;
  ZeroedArray(ZeroedArray&& other) noexcept { *this = std::move(other); }
  ZeroedArray& operator=(ZeroedArray&& other) noexcept {
    if (this != &other) {
      release();
      words_ = std::exchange(other.words_, nullptr);
      size_ = std::exchange(other.size_, 0);
      bytes_ = std::exchange(other.bytes_, 0);
    }
    return *this;
  }
  ~ZeroedArray() { release(); }
  std::size_t size() const { return size_; }
  W& operator[](std::size_t i) { return words_[i]; }
  W operator[](std::size_t i) const { return words_[i]; }
  // Grows to `count` words (no-op when not larger), the new ones zero. Amortised O(1) per word.
  void grow(std::size_t count) {
    if (count <= size_) return;
    if (count * sizeof(W) > bytes_) {
      const std::size_t wanted = std::max(count * sizeof(W), 2 * bytes_);
      words_ = static_cast<W*>(zeroed_grow(words_, bytes_, wanted));
    }
    size_ = count;
  }

 private:
  void release() {
    if (words_) zeroed_free(words_);
    words_ = nullptr;
    size_ = bytes_ = 0;
  }
  W* words_ = nullptr;
  std::size_t size_ = 0;   // words in use; those past it up to bytes_ are zero too
  std::size_t bytes_ = 0;  // the allocation
};

// Address space reserved per pool for its flat first components (see Region): 1 GiB, so a World
// with a few thousand pools stays inside the address space sanitizers leave to the program.
inline constexpr std::size_t kRegionBytes = std::size_t{1} << 30;

// kRegionBytes of address space reserved for the first components of a pool and committed page by
// page as it grows, so that they form one array and a look-up by dense position is one index
// (Linux; where it is missing or refused, reserve() returns false and the pool's pages all come
// from blocks). Reserving costs address space only, and the mapping asks for transparent huge
// pages. A released region is kept for the next pool (its committed pages stay faulted in, up to
// 64 MiB in the process), so it may hold earlier bytes: construct before reading.
class Region {
 public:
  Region() = default;
  Region(const Region&) = delete;
  Region& operator=(const Region&) = delete;
  ~Region();
  // Reserves kRegionBytes, 2 MiB aligned. False (nothing reserved) when the platform or the OS
  // refuses, or regions are turned off.
  bool reserve();
  // Turns reservations on (the default) or off for pools made from now on, process-wide: off for
  // hosts that must not reserve address space (a low `ulimit -v`), and for tests of the blocks.
  static void enable(bool on);
  // Makes the first `bytes` readable and writable. Precondition: bytes <= the reservation.
  // Throws std::bad_alloc when the OS refuses.
  void commit(std::size_t bytes);
  std::byte* data() const { return base_; }

 private:
  void* mapping_ = nullptr;
  std::size_t mapping_bytes_ = 0;
  std::byte* base_ = nullptr;
  std::size_t committed_ = 0;
};

// The type-independent half of a component pool (see the header comment for the layout). Dense
// entities and ticks live in pages of kPageSize like the components, so nothing is ever copied
// when a pool grows.
class PoolBase {
 public:
  PoolBase() = default;
  PoolBase(const PoolBase&) = delete;
  PoolBase& operator=(const PoolBase&) = delete;
  virtual ~PoolBase() = default;

  // Dense slots, tombstones included.
  std::uint32_t size() const { return size_; }
  std::uint32_t live() const { return size_ - tombstones_; }

  // Entity index and change tick of a dense slot; a tombstone's index is kNone. (Generations are
  // not stored: a pool only holds components of alive entities.)
  std::uint32_t& index(std::uint32_t pos) { return index_pages_[pos >> kPageShift][pos & (kPageSize - 1)]; }
  std::uint32_t index(std::uint32_t pos) const { return index_pages_[pos >> kPageShift][pos & (kPageSize - 1)]; }
  std::uint64_t& tick(std::uint32_t pos) { return tick_pages_[pos >> kPageShift][pos & (kPageSize - 1)]; }
  std::uint64_t tick(std::uint32_t pos) const { return tick_pages_[pos >> kPageShift][pos & (kPageSize - 1)]; }
  const std::uint32_t* index_page(std::uint32_t page) const { return index_pages_[page]; }

  // Dense position of the entity with this index, or kNone. (A sparse entry holds the position
  // plus one, so the zero of fresh memory means none, and 0 - 1 is kNone.)
  std::uint32_t find(std::uint32_t index) const { return (index < sparse_.size() ? sparse_[index] : 0u) - 1u; }
  // As find(), trying `hint` first: pools filled in the same order line up, so a view's other
  // pools are usually at the lead pool's position.
  std::uint32_t find(std::uint32_t index, std::uint32_t hint) const {
    if (hint < size_ && this->index(hint) == index) return hint;
    return find(index);
  }
  // As find(), without the range check. Precondition: the entity with this index has a component here.
  std::uint32_t position(std::uint32_t index) const { return sparse_[index] - 1u; }

  // The sparse entry of the entity with this index (its position plus one; 0: no component
  // here), the array grown to hold it. The reference stays valid until the next call grows it.
  std::uint32_t& sparse_entry(std::uint32_t entity_index) {
    if (entity_index >= sparse_.size())
      sparse_.grow(std::max<std::size_t>(std::size_t{entity_index} + 1, kPageSize));
    return sparse_[entity_index];
  }
  // Appends entity `index`, whose sparse entry is `entry` (its component must already be
  // constructed at position size()). Precondition: size() < capacity().
  void push(std::uint32_t entity_index, std::uint32_t& entry, std::uint64_t tick_value) {
    const std::uint32_t pos = size_;
    entry = pos + 1;
    index(pos) = entity_index;
    tick(pos) = tick_value;
    ++size_;
  }
  // Indexed storage: entity `entity_index`, whose sparse entry is `entry`, takes slot
  // entity_index (its component must already be constructed there); the slots between the old
  // size() and it become holes. Precondition: entity_index < capacity() and the slot is a hole
  // or at or past size().
  void put(std::uint32_t entity_index, std::uint32_t& entry, std::uint64_t tick_value);
  // Indexed storage: the bookkeeping of removing entity `removed` from slot `pos` (its component
  // already destroyed): the slot becomes a hole, and trailing holes are dropped. While `iterating`
  // they stay; returns true when the hole is the last slot (compact() drops it afterwards).
  bool vacate(std::uint32_t pos, std::uint32_t removed, bool iterating);
  // Removes the component at `pos`: swap-and-pop, or a tombstone while `iterating` (indexed
  // storage: always a hole). Returns true when the pool then needs compact().
  bool erase(std::uint32_t pos, bool iterating);
  // Indexed storage: shrinks size() to the last slot that holds a component.
  void drop_trailing_holes();
  // Swap-and-pop of slot `pos`, which holds entity `removed`, for the entities, ticks and sparse
  // array: the last slot's entity takes `pos`. Returns that last slot, whose component the caller
  // moves to `pos` (unless they are the same) and destroys.
  std::uint32_t pop_slot(std::uint32_t pos, std::uint32_t removed) {
    const std::uint32_t last = size_ - 1;
    ++layout_version_;
    sparse_[removed] = 0;
    if (pos != last) {
      const std::uint32_t moved = index(last);
      index(pos) = moved;
      tick(pos) = tick(last);
      sparse_[moved] = pos + 1;
    }
    --size_;
    return last;
  }
  // Removes tombstones, keeping the order of the survivors (indexed storage: the trailing holes).
  void compact();
  // Exchanges two dense slots: components, entities and ticks. Precondition: no tombstones.
  void swap_slots(std::uint32_t a, std::uint32_t b);
  // Slots with room for an entity, its tick and its component.
  std::uint32_t capacity() const { return capacity_; }
  // Allocates room for `count` slots, so that filling up to it allocates nothing.
  void reserve(std::uint32_t count);
  // Calls the connected listeners (those connected during the call included).
  void fire(World& world, std::vector<std::shared_ptr<Listener>>& listeners, Entity e);
  // Drops disconnected listeners unless an event of this pool is firing.
  void prune_listeners();

  std::uint32_t tombstones_ = 0;  // tombstones and, in an indexed pool, holes
  bool compact_pending_ = false;
  bool indexed_ = false;  // Storage::Indexed: slot = entity index
  // Bumped whenever an existing slot may change its entity (erase, compact); appends keep it.
  std::uint64_t layout_version_ = 0;
  // A view's memo: this pool's first aligned_count_ slots hold the same entities as
  // aligned_with_'s, valid while both layout versions equal aligned_versions_. It spares
  // multi-component views re-comparing the entity arrays of pools filled in the same order.
  const PoolBase* aligned_with_ = nullptr;
  std::uint64_t aligned_versions_[2] = {0, 0};
  std::uint32_t aligned_count_ = 0;
  std::vector<std::shared_ptr<Listener>> on_add_, on_remove_;
  int firing_ = 0;
  ComponentId id_ = 0;                   // the type this pool holds
  std::uint32_t bit_ = 0;                // this pool's bit in the World's per-entity masks
  GroupBase* owner_ = nullptr;           // the group that orders this pool, if any
  std::vector<GroupBase*> groups_;       // every group that has this pool's type, owned or observed
  // destroy()'s removal of one entity's components, pool after pool: pops the component of
  // entity `entity_index` from this pool (the lowest bit of `bits`, the entity's mask word), then
  // goes on, by a tail call, with the pool of the next bit in `pools` (the World's pools by bit)
  // while that pool's plain_pop_ is set. Returns the bits of the components left (0: all gone).
  using PopFn = std::uint64_t (*)(PoolBase&, std::uint32_t entity_index, std::uint64_t bits, PoolBase* const* pools);
  // Pool<T>'s PopFn: the typed swap-and-pop, without a virtual call per step.
  PopFn typed_pop_ = nullptr;
  // typed_pop_ while removing a component needs nothing else (no on_remove listener, no group),
  // else null. Kept by refresh_plain_pop() whenever listeners or groups change.
  PopFn plain_pop_ = nullptr;
  // The PopFn step after this pool's pop: on to the next bit's pool, or back with what is left.
  static std::uint64_t pop_next(std::uint32_t entity_index, std::uint64_t bits, PoolBase* const* pools) {
    bits &= bits - 1;
    if (bits == 0) return 0;
    PoolBase& next = *pools[std::countr_zero(bits)];
    return next.plain_pop_ ? next.plain_pop_(next, entity_index, bits, pools) : bits;
  }
  void refresh_plain_pop() { plain_pop_ = on_remove_.empty() && groups_.empty() ? typed_pop_ : nullptr; }

 protected:
  virtual void destroy_at(std::uint32_t pos) = 0;
  virtual void relocate(std::uint32_t from, std::uint32_t to) = 0;  // move-construct `to`, destroy `from`
  virtual void move_last_into(std::uint32_t pos, std::uint32_t last) = 0;  // move-assign `pos`, destroy `last`
  virtual void swap_components(std::uint32_t a, std::uint32_t b) = 0;
  // Room for at least `count` components; returns the room, in slots.
  virtual std::uint32_t reserve_components(std::uint32_t count) = 0;
  // to.add(dst, a copy of the component at `pos`); false (nothing done) when the type cannot be copied.
  virtual bool copy_to(std::uint32_t pos, World& to, Entity dst) = 0;
  friend class penumbra::World;

 private:
  void grow();  // adds index and tick pages

  std::uint32_t size_ = 0;
  std::uint32_t capacity_ = 0;
  std::vector<std::uint32_t*> index_pages_;  // kPageSize entity indices each, inside blocks_
  std::vector<std::uint64_t*> tick_pages_;   // kPageSize ticks each, inside blocks_
  std::vector<Block> blocks_;                // the allocations behind index_pages_ and tick_pages_
  ZeroedArray<std::uint32_t> sparse_;        // per entity index: dense position + 1 (0: none)
};

template <class T>
class Pool final : public PoolBase {
 public:
  static constexpr bool kIndexed = kComponentStorage<T> == Storage::Indexed;

  Pool() {
    indexed_ = kIndexed;
    typed_pop_ = [](PoolBase& p, std::uint32_t entity_index, std::uint64_t bits, PoolBase* const* pools) {
      static_cast<Pool&>(p).pop(p.position(entity_index), entity_index);
      return pop_next(entity_index, bits, pools);
    };
    refresh_plain_pop();
  }
  ~Pool() override {
    for (std::uint32_t i = 0; i < size(); ++i)
      if (index(i) != kNone) at(i).~T();
  }

  // The component at dense position `pos`: one index into the flat region, else through the pages.
  T& at(std::uint32_t pos) { return pos < flat_slots_ ? flat_[pos] : pages_[pos >> kPageShift][pos & (kPageSize - 1)]; }
  const T& at(std::uint32_t pos) const {
    return pos < flat_slots_ ? flat_[pos] : pages_[pos >> kPageShift][pos & (kPageSize - 1)];
  }
  T* page(std::uint32_t p) { return pages_[p]; }
  // erase(pos, false) without the virtual calls; `entity_index` is the entity at `pos`.
  void pop(std::uint32_t pos, std::uint32_t entity_index) {
    if constexpr (kIndexed) {
      at(pos).~T();
      vacate(pos, entity_index, false);
      return;
    }
    const std::uint32_t last = pop_slot(pos, entity_index);
    T& from = at(last);
    if (pos != last) at(pos) = std::move(from);
    from.~T();
  }

  // Constructs a new component at the end of the pool (indexed storage: at slot entity_index).
  template <class... Args>
  T& emplace(std::uint32_t entity_index, std::uint32_t& entry, std::uint64_t tick, Args&&... args) {
    const std::uint32_t pos = kIndexed ? entity_index : size();
    if (pos >= capacity()) reserve(pos + 1);
    T* slot = &at(pos);
    if constexpr (std::is_constructible_v<T, Args&&...>)
      ::new (static_cast<void*>(slot)) T(std::forward<Args>(args)...);
    else  // an aggregate from its members (compilers without C++20's parenthesised aggregate init)
      ::new (static_cast<void*>(slot)) T{std::forward<Args>(args)...};
    if constexpr (kIndexed)
      put(entity_index, entry, tick);
    else
      push(entity_index, entry, tick);
    return *slot;
  }

 private:
  void destroy_at(std::uint32_t pos) override { at(pos).~T(); }
  void relocate(std::uint32_t from, std::uint32_t to) override {
    ::new (static_cast<void*>(&at(to))) T(std::move(at(from)));
    at(from).~T();
  }
  void move_last_into(std::uint32_t pos, std::uint32_t last) override {
    at(pos) = std::move(at(last));
    at(last).~T();
  }
  void swap_components(std::uint32_t a, std::uint32_t b) override {
    T held(std::move(at(a)));
    at(a) = std::move(at(b));
    at(b) = std::move(held);
  }
  bool copy_to(std::uint32_t pos, World& to, Entity dst) override;
  std::uint32_t reserve_components(std::uint32_t count) override {
    while ((std::size_t{count} + kPageSize - 1) / kPageSize > pages_.size()) add_block();
    return static_cast<std::uint32_t>(std::min<std::size_t>(pages_.size() * kPageSize, kNone));
  }
  // As many new pages as there are (one at first): committed in the region while it has room,
  // then a block. Pages stay put, and consecutive pages are mostly adjacent in memory, which keeps
  // iteration streaming.
  void add_block() {
    const std::size_t count = pages_.empty() ? 1 : pages_.size();
    if (pages_.empty() && region_pages() > 0 && region_.reserve())
      flat_ = reinterpret_cast<T*>(region_.data());
    if (flat_ && pages_.size() < region_pages()) {
      const std::size_t pages = std::min(pages_.size() + count, region_pages());
      region_.commit(pages * kPageSize * sizeof(T));
      while (pages_.size() < pages) pages_.push_back(flat_ + pages_.size() * kPageSize);
      flat_slots_ = static_cast<std::uint32_t>(pages * kPageSize);
      return;
    }
    T* block = static_cast<T*>(allocate_block(sizeof(T) * kPageSize * count, alignof(T)));
    blocks_.emplace_back(block);
    for (std::size_t i = 0; i < count; ++i) pages_.push_back(block + i * kPageSize);
  }

  // The region's pages: as many as kRegionBytes holds, at most 2^31 slots.
  static constexpr std::size_t region_pages() {
    return std::min(kRegionBytes / (sizeof(T) * kPageSize), (std::size_t{1} << 31) / kPageSize);
  }

  Region region_;
  T* flat_ = nullptr;             // the region's components (null: no region)
  std::uint32_t flat_slots_ = 0;  // committed slots of the region: positions below it index flat_
  std::vector<T*> pages_;         // kPageSize components each, in the region, then inside blocks_
  std::vector<Block> blocks_;     // the allocations after the region
};

template <class Fn, class... T>
inline constexpr bool kTakesEntity = std::is_invocable_v<Fn&, Entity, T&...>;

// A group's membership and the pools it orders (see "Groups" at the top).
class GroupBase {
 public:
  std::vector<PoolBase*> owned, observed;
  std::vector<ComponentId> types;  // of owned and observed, sorted
  std::uint32_t size = 0;          // members: slots [0, size) of every owned pool
  bool dirty = false;              // membership changed during iteration; repacked when it ends

  bool has_type(ComponentId id) const { return std::binary_search(types.begin(), types.end(), id); }
  // Whether the entity is a member. Precondition: !dirty.
  bool member(std::uint32_t index) const {
    const std::uint32_t pos = owned[0]->find(index);
    return pos != kNone && pos < size;
  }
  // Whether the entity has every one of the group's types.
  bool qualifies(std::uint32_t index) const;
  // Moves a qualifying non-member to slot `size` of each owned pool. Preconditions: !dirty, no tombstones.
  void enter(std::uint32_t index);
  // Moves a member to slot size - 1 of each owned pool and drops it. Preconditions as enter().
  void leave(std::uint32_t index);
  // Packs every qualifying entity from scratch, in the first owned pool's order. O(its size).
  void repack();
};

}  // namespace detail

// Names the observed types of a group: world.group<Owned...>(observe<Observed...>).
template <class... T>
struct Observe {};
template <class... T>
inline constexpr Observe<T...> observe{};

template <class T>
class ComponentPool;

template <class... T>
class View;

class World {
 public:
  World();
  ~World();
  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  // --- Entities ---------------------------------------------------------------------------
  // A new entity without components. O(1) amortised.
  Entity create();
  // out.size() new entities into `out`, the same handles as that many create() calls. O(out.size()).
  void create(std::span<Entity> out);
  // Removes every component (each on_remove fires while the entity is still alive), then bumps
  // the index's generation so every handle to it turns stale. A stale or null handle is ignored.
  // Components go in the order their types were first used in this World, so an on_remove
  // listener sees those of later types still there. Cost: O(number of components the entity
  // has); in a World of up to 64 component types, a pool with no on_remove listener and no group
  // takes a typed swap-and-pop (no virtual call, nothing allocated).
  void destroy(Entity e);
  // destroy() of each, in order.
  void destroy(std::span<const Entity> entities);
  // False for null and stale handles.
  bool alive(Entity e) const {
    return e.index < slots_.size() && slots_[e.index] == e.generation;
  }
  // Number of alive entities.
  std::size_t entity_count() const { return entities_.alive; }
  // The handle of the alive entity with this index (for code that stores indices).
  // Precondition: an entity with this index is alive.
  Entity handle(std::uint32_t index) const { return Entity{index, slots_[index]}; }
  // As handle(), for indices from untrusted places (files): null when no alive entity has it.
  Entity find_entity(std::uint32_t index) const {
    return index < slots_.size() && (slots_[index] & kDeadBit) == 0 ? Entity{index, slots_[index]} : Entity::null();
  }

  // --- Components (T: a movable object type) ------------------------------------------------
  // Constructs T(args...) (aggregates too), or replaces the present one; stamps the current tick.
  // on_add fires only when the component was absent. Precondition: alive(e) (asserted).
  template <class T, class... Args>
  T& add(Entity e, Args&&... args);
  // add<T>(e, value) for each entity in order (events, ticks and groups as add()), allocating the
  // pool's room once. Preconditions as add().
  template <class T>
  void insert(std::span<const Entity> entities, const T& value = T{});
  // As above with values[i] for entities[i]. Precondition: the sizes match (asserted).
  template <class T>
  void insert(std::span<const Entity> entities, std::span<const T> values);
  // False when absent or the handle is stale.
  template <class T>
  bool has(Entity e) const {
    const auto* p = pool_if<T>();
    return p && alive(e) && p->find(e.index) != detail::kNone;
  }
  // Precondition: has<T>(e) (asserted). O(1): two page look-ups.
  template <class T>
  T& get(Entity e) {
    T* c = try_get<T>(e);
    assert(c && "World::get: the entity lacks this component or the handle is stale");
    return *c;
  }
  template <class T>
  const T& get(Entity e) const {
    const T* c = try_get<T>(e);
    assert(c && "World::get: the entity lacks this component or the handle is stale");
    return *c;
  }
  // nullptr when absent or the handle is stale.
  template <class T>
  T* try_get(Entity e) {
    auto* p = pool_if<T>();
    if (!p || !alive(e)) return nullptr;
    const std::uint32_t pos = p->find(e.index);
    return pos == detail::kNone ? nullptr : &p->at(pos);
  }
  template <class T>
  const T* try_get(Entity e) const {
    const auto* p = pool_if<T>();
    if (!p || !alive(e)) return nullptr;
    const std::uint32_t pos = p->find(e.index);
    return pos == detail::kNone ? nullptr : &p->at(pos);
  }
  // Fires on_remove (the component still readable), then removes it. False when absent.
  template <class T>
  bool remove(Entity e);
  // Copies each component of `src` onto `dst` of `to` (this World or another) with to.add(), in
  // the order their types were first used here: a type dst already has is replaced, on_add fires
  // for the others. Entity handles inside components (Parent, Children, ...) are copied as they
  // are: remap them where the copy needs its own. Types that cannot be copied (move-only) are
  // skipped; returns how many were. Preconditions: alive(src), to.alive(dst), and src != dst when
  // `to` is this World (asserted). Cost: O(components of src), each a copy construction.
  std::size_t copy_components(Entity src, World& to, Entity dst);
  // get() and stamp the current tick: use it for writes that systems should notice.
  template <class T>
  T& patch(Entity e);
  // The tick at which e's T was last added or patched; 0 when absent.
  template <class T>
  std::uint64_t changed_tick(Entity e) const {
    const auto* p = pool_if<T>();
    if (!p || !alive(e)) return 0;
    const std::uint32_t pos = p->find(e.index);
    return pos == detail::kNone ? 0 : p->tick(pos);
  }
  // Number of entities with T. O(1).
  template <class T>
  std::size_t count() const {
    const auto* p = pool_if<T>();
    return p ? p->live() : 0;
  }
  // A handle on T's pool for repeated look-ups, the pool found once (see ComponentPool).
  template <class T>
  ComponentPool<T> pool();

  // --- Views --------------------------------------------------------------------------------
  // Entities having all of T...; callbacks take (Entity, T&...) or (T&...). See View below.
  template <class... T>
  View<T...> view();
  // Shorthand for view<T...>().each(fn).
  template <class... T, class Fn>
  void each(Fn&& fn);
  // Declares the group of Owned... and Observed... (see "Groups" at the top) and returns the view
  // that walks it; calling it again with the same types just returns the view. The first call
  // packs the pools (O(size of the first owned pool)); then each add or remove of one of these
  // types costs a swap per owned pool. Throws std::logic_error when an owned type is already
  // owned by another group.
  template <class... Owned, class... Observed>
  View<Owned..., Observed...> group(Observe<Observed...> = {});

  // --- Change ticks -------------------------------------------------------------------------
  std::uint64_t tick() const { return tick_; }
  // Advances and returns the tick. update() and run_phase() do this around every system; call
  // it when running a change-tracking pass by hand (see update_world_transforms()).
  std::uint64_t advance_tick() { return ++tick_; }

  // --- Systems ------------------------------------------------------------------------------
  // Registers a system after those of its phase. Not during update(). A system that writes a
  // component it did not declare in `writes` (add/patch/remove) fails an assertion in debug builds;
  // writes through get() are not seen (and not stamped): use patch() for writes others must notice.
  void add_system(SystemDesc desc);
  // Runs the systems of one phase, then advances the tick.
  void run_phase(Phase phase, double dt);
  // Runs every phase in order; records each system's milliseconds.
  void update(double dt);
  // Registered systems in execution order, with their declared access and last timings.
  const std::vector<SystemInfo>& systems() const { return systems_; }

  // --- Events -------------------------------------------------------------------------------
  // on_add fires after T was added to an entity; on_remove before T is removed (or its entity
  // destroyed), while get<T>() still works. Listeners may change the World.
  template <class T>
  Connection on_add(std::function<void(World&, Entity)> fn) {
    auto& p = storage<T>();
    return connect(p, p.on_add_, std::move(fn));
  }
  template <class T>
  Connection on_remove(std::function<void(World&, Entity)> fn) {
    auto& p = storage<T>();
    return connect(p, p.on_remove_, std::move(fn));
  }

  // --- Resources ----------------------------------------------------------------------------
  // World-level singleton of type T (default-constructed on first use); stable address.
  template <class T>
  T& resource() {
    const ComponentId id = component_id<T>();
    if (id >= resources_.size()) resources_.resize(id + 1);
    if (!resources_[id]) resources_[id] = std::make_shared<T>();
    return *static_cast<T*>(resources_[id].get());
  }

 private:
  template <class... T>
  friend class View;
  template <class T>
  friend class ComponentPool;

  // The pool of T (cv-qualifiers ignored, so views may name const components).
  template <class T, class U = std::remove_cv_t<T>>
  detail::Pool<U>& storage() {
    const ComponentId id = component_id<U>();
    if (id < pools_.size() && pools_[id]) return static_cast<detail::Pool<U>&>(*pools_[id]);
    return static_cast<detail::Pool<U>&>(add_pool(id, std::make_unique<detail::Pool<U>>()));
  }
  detail::PoolBase& add_pool(ComponentId id, std::unique_ptr<detail::PoolBase> pool);
  template <class T, class U = std::remove_cv_t<T>>
  detail::Pool<U>* pool_if() {
    const ComponentId id = component_id<U>();
    return id < pools_.size() ? static_cast<detail::Pool<U>*>(pools_[id].get()) : nullptr;
  }
  template <class T, class U = std::remove_cv_t<T>>
  const detail::Pool<U>* pool_if() const {
    const ComponentId id = component_id<U>();
    return id < pools_.size() ? static_cast<const detail::Pool<U>*>(pools_[id].get()) : nullptr;
  }

  // add() into T's pool `p`.
  template <class T, class... Args>
  T& add_to(detail::Pool<T>& p, Entity e, Args&&... args);
  // The word of entity `index`'s mask that holds `bit`, and the bit within it.
  std::uint64_t& mask_word(std::uint32_t index, std::uint32_t bit) {
    return masks_[std::size_t{index} * mask_words_ + bit / 64];
  }
  static std::uint64_t mask_bit(std::uint32_t bit) { return std::uint64_t{1} << (bit % 64); }
  // Zeroed mask rows up to the entity slots' capacity (at least 64).
  void add_mask_rows();
  // After e gained p's component: the groups it now completes.
  void join_groups(detail::PoolBase& p, std::uint32_t index);
  // Before e loses p's component: the groups it leaves.
  void leave_groups(detail::PoolBase& p, std::uint32_t index);
  // Removes e's component from `p` (firing on_remove); false when absent.
  bool remove_from(detail::PoolBase& p, Entity e);
  // destroy()'s general path; false when a listener destroyed e.
  bool destroy_components(Entity e);
  // destroy()'s last step: the generation bumped, the index freed.
  void release(Entity e);
  // The removal itself: clears the mask bit, erases slot `pos` (a tombstone while iterating).
  void erase_at(detail::PoolBase& p, std::uint32_t index, std::uint32_t pos);
  detail::GroupBase& make_group(std::vector<detail::PoolBase*> owned, std::vector<detail::PoolBase*> observed);
  Connection connect(detail::PoolBase& p, std::vector<std::shared_ptr<detail::Listener>>& list,
                     std::function<void(World&, Entity)> fn);
  // Debug check that a running system declared a write to `id`.
  bool write_declared(ComponentId id) const;

  // Iteration scope: structural removals leave tombstones until the outermost scope ends.
  void begin_iteration() { ++iterating_; }
  void end_iteration() {
    if (--iterating_ == 0 && (!pending_compaction_.empty() || !dirty_groups_.empty())) finish_iteration();
  }
  void finish_iteration();  // compacts the pools with tombstones, then repacks dirty groups
  struct IterationScope {
    World& w;
    explicit IterationScope(World& world) : w(world) { w.begin_iteration(); }
    ~IterationScope() { w.end_iteration(); }
    IterationScope(const IterationScope&) = delete;
    IterationScope& operator=(const IterationScope&) = delete;
  };

  // Per entity index: its generation while alive; generation | kDeadBit while free (handles never
  // carry that bit, so one compare tells alive handles). An index whose 31-bit generation is
  // exhausted is retired: dead forever, never reused.
  static constexpr std::uint32_t kDeadBit = 0x80000000u;
  std::vector<std::uint32_t> slots_;
  // The free indices, most recently freed first: free_head, then the index held in word 0 of
  // each free index's mask row (kNone ends the list). The row is otherwise unused while the index
  // is free, and destroy() has just read it, so freeing writes no memory a live entity did not use.
  // With the counts of alive and retired indices; a moved-from World is left with none.
  struct EntityList {
    std::uint32_t free_head = detail::kNone;
    std::size_t alive = 0, retired = 0;
    EntityList() = default;
    EntityList(EntityList&& other) noexcept { *this = std::move(other); }
    EntityList& operator=(EntityList&& other) noexcept {
      free_head = std::exchange(other.free_head, detail::kNone);
      alive = std::exchange(other.alive, 0);
      retired = std::exchange(other.retired, 0);
      return *this;
    }
  };
  EntityList entities_;
  // Pools by ComponentId (null for types this World never used), and the same pools by bit_.
  std::vector<std::unique_ptr<detail::PoolBase>> pools_;
  std::vector<detail::PoolBase*> by_bit_;
  // Per entity index, mask_words_ 64-bit words: bit b set while by_bit_[b] holds its component.
  // At least one row per entity slot; a free index's row is zero but for its free-list link.
  detail::ZeroedArray<std::uint64_t> masks_;
  std::uint32_t mask_words_ = 1;
  std::vector<std::unique_ptr<detail::GroupBase>> groups_;
  std::vector<detail::GroupBase*> dirty_groups_;
  std::vector<std::shared_ptr<void>> resources_;
  std::uint64_t tick_ = 1;
  int iterating_ = 0;
  std::vector<detail::PoolBase*> pending_compaction_;
  // Removals whose on_remove listeners are running: a listener that removes the same component
  // again (for example by destroying the entity) does not fire it twice.
  std::vector<std::pair<const detail::PoolBase*, std::uint32_t>> removing_;

  std::vector<SystemInfo> systems_;
  std::vector<std::function<void(World&, const SystemContext&)>> system_fns_;
  int running_system_ = -1;  // index into systems_ while one runs
};

// Iterates the entities that have all of T... . Obtain with World::view<T...>(); cheap to create.
// Cost: one pass over the smallest pool (each) or over the first pool (each_changed), plus one
// look-up per other component; a view of exactly a group's types (each, count) walks only the
// group's members, its owned components without look-ups. Structural changes inside the callback
// follow the rules at the top.
template <class... T>
class View {
  static_assert(sizeof...(T) >= 1, "a view needs at least one component type");

 public:
  explicit View(World& world) : world_(&world) {}

  // Calls fn(Entity, T&...) or fn(T&...) for each entity with all of T... .
  template <class Fn>
  void each(Fn&& fn) {
    if constexpr (sizeof...(T) == 1) {
      each_single(fn);
    } else {
      const Pools pools{&world_->storage<T>()...};
      if (const detail::GroupBase* g = group_of(pools, Indices{})) {
        const bool all_owned = owns_all(pools, *g, Indices{});
        dispatch(pools, first_owned(pools, *g, Indices{}), fn, All{}, g->size, all_owned, Indices{});
      } else {
        dispatch(pools, smallest(pools, Indices{}), fn, All{}, kWholePool, false, Indices{});
      }
    }
  }

  // As each(), restricted to entities whose first listed component was added or patched after
  // tick `since` (pass SystemContext::last_run).
  template <class Fn>
  void each_changed(std::uint64_t since, Fn&& fn) {
    const Pools pools{&world_->storage<T>()...};
    each_lead<0>(pools, fn, ChangedAfter{std::get<0>(pools), since}, kWholePool, false, Indices{});
  }

  // Number of entities with all of T... (one pass for several components).
  std::size_t count() {
    if constexpr (sizeof...(T) > 1) {
      const Pools pools{&world_->storage<T>()...};
      if (const detail::GroupBase* g = group_of(pools, Indices{}); g && !has_tombstones(pools, Indices{})) return g->size;
    }
    std::size_t n = 0;
    each([&n](Entity, T&...) { ++n; });
    return n;
  }

  // The entities with all of T... in increasing index order: an order that does not depend on the
  // history of the pools, for work that must be deterministic (bakes, input hashes).
  std::vector<Entity> sorted_entities() {
    std::vector<Entity> out;
    each([&out](Entity e, T&...) { out.push_back(e); });
    std::sort(out.begin(), out.end(), [](Entity a, Entity b) { return a.index < b.index; });
    return out;
  }

 private:
  using First = std::tuple_element_t<0, std::tuple<T...>>;
  using Pools = std::tuple<detail::Pool<std::remove_cv_t<T>>*...>;
  using Indices = std::index_sequence_for<T...>;
  static constexpr std::uint32_t kWholePool = detail::kNone;  // each_lead's limit: every slot of the lead

  // Which of the lead pool's slots to visit.
  struct All {
    static constexpr bool kAll = true;
    bool operator()(std::uint32_t) const { return true; }
  };
  struct ChangedAfter {
    static constexpr bool kAll = false;
    const detail::PoolBase* lead;
    std::uint64_t since;
    bool operator()(std::uint32_t pos) const { return lead->tick(pos) > since; }
  };

  // One component: a plain loop over each page's contiguous array; tombstones are checked only
  // when the pool has some.
  template <class Fn>
  void each_single(Fn& fn) {
    auto& p = world_->storage<First>();
    World::IterationScope scope(*world_);
    const std::uint32_t n = p.size();
    for (std::uint32_t base = 0; base < n; base += detail::kPageSize) {
      First* data = p.page(base >> detail::kPageShift);
      const std::uint32_t* indices = p.index_page(base >> detail::kPageShift);
      const std::uint32_t end = n - base < detail::kPageSize ? n - base : detail::kPageSize;
      for (std::uint32_t i = 0; i < end; ++i) {
        if (p.tombstones_ != 0 && indices[i] == detail::kNone) continue;
        if constexpr (detail::kTakesEntity<Fn, First>)
          fn(world_->handle(indices[i]), data[i]);
        else
          fn(data[i]);
      }
    }
  }

  template <std::size_t... I>
  static std::size_t smallest(const Pools& pools, std::index_sequence<I...>) {
    // An indexed pool's walk covers its holes too.
    const auto cost = [](const detail::PoolBase* p) { return p->indexed_ ? p->size() : p->live(); };
    const std::uint32_t sizes[] = {cost(std::get<I>(pools))...};
    std::size_t best = 0;
    for (std::size_t i = 1; i < sizeof...(I); ++i)
      if (sizes[i] < sizes[best]) best = i;
    return best;
  }

  // The group of exactly these types, when it is packed.
  template <std::size_t... I>
  static const detail::GroupBase* group_of(const Pools& pools, std::index_sequence<I...>) {
    const detail::GroupBase* g = nullptr;
    ((g = g ? g : std::get<I>(pools)->owner_), ...);
    if (!g || g->dirty || g->types.size() != sizeof...(T)) return nullptr;
    return (g->has_type(component_id<T>()) && ...) ? g : nullptr;
  }
  template <std::size_t... I>
  static bool owns_all(const Pools& pools, const detail::GroupBase& g, std::index_sequence<I...>) {
    return ((std::get<I>(pools)->owner_ == &g) && ...);
  }
  template <std::size_t... I>
  static std::size_t first_owned(const Pools& pools, const detail::GroupBase& g, std::index_sequence<I...>) {
    std::size_t first = sizeof...(I);
    ((first = first == sizeof...(I) && std::get<I>(pools)->owner_ == &g ? I : first), ...);
    return first;
  }
  template <std::size_t... I>
  static bool has_tombstones(const Pools& pools, std::index_sequence<I...>) {
    return ((std::get<I>(pools)->tombstones_ != 0) || ...);
  }

  // Runs each_lead<L> for the runtime lead index, so the lead's position needs no look-up.
  template <class Fn, class Filter, std::size_t... I>
  void dispatch(const Pools& pools, std::size_t lead, Fn& fn, const Filter& filter, std::uint32_t limit,
                bool lined_up, std::index_sequence<I...>) {
    ((lead == I ? each_lead<I>(pools, fn, filter, limit, lined_up, Indices{}) : void()), ...);
  }

  // Where a pool's page `page` starts: its components, its entities and how many slots it holds
  // (limit 0 when the pool is shorter). Pages never move, so a cursor survives additions.
  template <class C>
  struct Cursor {
    C* data = nullptr;
    const std::uint32_t* indices = nullptr;
    std::uint32_t limit = 0;
  };
  template <class C>
  static Cursor<C> cursor(detail::Pool<std::remove_cv_t<C>>* p, std::uint32_t page) {
    const std::uint32_t base = page << detail::kPageShift;
    if (base >= p->size()) return {};
    const std::uint32_t left = p->size() - base;
    return {p->page(page), p->index_page(page), left < detail::kPageSize ? left : detail::kPageSize};
  }

  // Walks the lead pool's first `limit` slots page by page (a group's members, or kWholePool);
  // the other pools are first tried at the same slot (pools filled in the same order line up,
  // and `lined_up` says a group guarantees it), then looked up through their sparse arrays.
  template <std::size_t L, class Fn, class Filter, std::size_t... I>
  void each_lead(const Pools& pools, Fn& fn, const Filter& filter, std::uint32_t limit, bool lined_up,
                 std::index_sequence<I...>) {
    const auto* lead = std::get<L>(pools);
    World::IterationScope scope(*world_);
    const std::uint32_t n = std::min(limit, lead->size());
    for (std::uint32_t base = 0; base < n; base += detail::kPageSize) {
      const std::uint32_t page = base >> detail::kPageShift;
      const std::tuple<Cursor<T>...> cursors{cursor<T>(std::get<I>(pools), page)...};
      const std::uint32_t* indices = std::get<L>(cursors).indices;
      const std::uint32_t end = n - base < detail::kPageSize ? n - base : detail::kPageSize;
      std::uint32_t i = 0;
      // Fast path: every pool holds this page's entities in the same slots and has no
      // tombstones, so the loop needs no look-up; it stops where a callback leaves a tombstone.
      if (Filter::kAll && (lined_up || aligned(pools, cursors, base, end, std::index_sequence<I...>{}))) {
        for (; i < end && !(std::get<I>(pools)->tombstones_ || ...); ++i) {
          if constexpr (detail::kTakesEntity<Fn, T...>)
            fn(world_->handle(indices[i]), std::get<I>(cursors).data[i]...);
          else
            fn(std::get<I>(cursors).data[i]...);
        }
      }
      for (; i < end; ++i) {
        const std::uint32_t index = indices[i];
        if (index == detail::kNone || !filter(base + i)) continue;
        const std::tuple<T*...> components{component<I, L>(std::get<I>(pools), std::get<I>(cursors), index, i)...};
        if (!((std::get<I>(components) != nullptr) && ...)) continue;
        if constexpr (detail::kTakesEntity<Fn, T...>)
          fn(world_->handle(index), *std::get<I>(components)...);
        else
          fn(*std::get<I>(components)...);
      }
    }
  }

  template <std::size_t... I>
  static bool aligned(const Pools& pools, const std::tuple<Cursor<T>...>& cursors, std::uint32_t base,
                      std::uint32_t end, std::index_sequence<I...>) {
    if (!(((std::get<I>(pools)->tombstones_ == 0) && ...) && ((std::get<I>(cursors).limit >= end) && ...)))
      return false;
    const detail::PoolBase& first = *std::get<0>(pools);
    const std::uint32_t* first_indices = std::get<0>(cursors).indices;
    return ((I == 0 || same_slots(first, *std::get<I>(pools), first_indices, std::get<I>(cursors).indices, base, end)) &&
            ...);
  }

  // Whether slots [base, base + end) of `b` hold the same entities as those of `a`: from b's memo
  // when it covers them, else by comparing the entity arrays (and extending the memo).
  static bool same_slots(const detail::PoolBase& a, detail::PoolBase& b, const std::uint32_t* a_indices,
                         const std::uint32_t* b_indices, std::uint32_t base, std::uint32_t end) {
    const bool memo = b.aligned_with_ == &a && b.aligned_versions_[0] == a.layout_version_ &&
                      b.aligned_versions_[1] == b.layout_version_;
    if (memo && base + end <= b.aligned_count_) return true;
    if (std::memcmp(a_indices, b_indices, end * sizeof(std::uint32_t)) != 0) return false;
    if (memo && b.aligned_count_ >= base) {
      b.aligned_count_ = base + end;
    } else if (!memo && base == 0) {
      b.aligned_with_ = &a;
      b.aligned_versions_[0] = a.layout_version_;
      b.aligned_versions_[1] = b.layout_version_;
      b.aligned_count_ = end;
    }
    return true;
  }

  template <std::size_t I, std::size_t L, class C>
  static C* component(detail::Pool<std::remove_cv_t<C>>* p, const Cursor<C>& c, std::uint32_t index, std::uint32_t i) {
    if constexpr (I == L) {
      return c.data + i;
    } else {
      if (i < c.limit && c.indices[i] == index) return c.data + i;
      const std::uint32_t at = p->find(index);
      return at == detail::kNone ? nullptr : &p->at(at);
    }
  }

  World* world_;
};

// A handle on one component pool of a World, for systems that look components up many times:
// the pool is found once (World::pool<T>()), so each get is two array look-ups (one for a type of
// indexed storage). Valid while the World lives and is not moved; the references it returns
// follow the rules at the top.
template <class T>
class ComponentPool {
  using U = std::remove_cv_t<T>;

 public:
  ComponentPool(World& world, detail::Pool<U>& pool) : world_(&world), pool_(&pool) {}

  // Whether e is alive and has T. O(1).
  bool contains(Entity e) const { return world_->alive(e) && pool_->find(e.index) != detail::kNone; }
  // Checked: nullptr when absent or the handle is stale. O(1): the generation, then two look-ups.
  T* try_get(Entity e) const {
    if (!world_->alive(e)) return nullptr;
    const std::uint32_t pos = pool_->find(e.index);
    return pos == detail::kNone ? nullptr : &pool_->at(pos);
  }
  // Unchecked: precondition contains(e), asserted in debug builds only. O(1): two look-ups, the
  // sparse entry and the component (indexed storage: the component alone).
  T& get(Entity e) const {
    assert(contains(e) && "ComponentPool::get: the entity lacks this component or the handle is stale");
    if constexpr (detail::Pool<U>::kIndexed)
      return pool_->at(e.index);
    else
      return pool_->at(pool_->position(e.index));
  }
  // The tick at which e's T was last added or patched; 0 when absent or the handle is stale.
  std::uint64_t changed_tick(Entity e) const {
    if (!world_->alive(e)) return 0;
    const std::uint32_t pos = pool_->find(e.index);
    return pos == detail::kNone ? 0 : pool_->tick(pos);
  }
  // Number of entities with T.
  std::size_t size() const { return pool_->live(); }

 private:
  const World* world_;
  detail::Pool<U>* pool_;
};

// --- World templates ---------------------------------------------------------------------------

template <class T>
bool detail::Pool<T>::copy_to(std::uint32_t pos, World& to, Entity dst) {
  if constexpr (std::is_copy_constructible_v<T>) {
    T copy(at(pos));  // taken first: `to` may be this World, whose groups an add may reorder
    to.add<T>(dst, std::move(copy));
    return true;
  } else {
    return false;
  }
}

inline void World::destroy(Entity e) {
  if (!alive(e)) return;
  // Components in bit order, as destroy_components() removes them: those of pools with nothing
  // to tell and no group by the pools' chain of typed swap-and-pops (PoolBase::PopFn), until one
  // needs the general path, which takes what is left. The chain covers Worlds with up to 64
  // component types (one mask word); the general path takes the components of wider ones.
  bool plain = iterating_ == 0 && mask_words_ == 1;
  if (plain) {
    std::uint64_t& word = masks_[e.index];
    if (word != 0) {
      detail::PoolBase& first = *by_bit_[std::countr_zero(word)];
      if (first.plain_pop_) word = first.plain_pop_(first, e.index, word, by_bit_.data());
      plain = word == 0;
    }
  }
  if (!plain && !destroy_components(e)) return;
  release(e);
}

inline void World::release(Entity e) {
  --entities_.alive;
  // Bump the generation so old handles turn stale; an exhausted index is retired, never reused.
  const std::uint32_t next = e.generation + 1;
  if (next == kDeadBit) {
    slots_[e.index] = kDeadBit | e.generation;
    ++entities_.retired;
  } else {
    slots_[e.index] = kDeadBit | next;
    masks_[std::size_t{e.index} * mask_words_] = entities_.free_head;  // the row is zero: its components are gone
    entities_.free_head = e.index;
  }
}

template <class T, class... Args>
T& World::add(Entity e, Args&&... args) {
  return add_to(storage<T>(), e, std::forward<Args>(args)...);
}

template <class T>
void World::insert(std::span<const Entity> entities, const T& value) {
  auto& p = storage<T>();
  p.reserve(p.size() + static_cast<std::uint32_t>(entities.size()));
  for (const Entity e : entities) add_to(p, e, value);
}

template <class T>
void World::insert(std::span<const Entity> entities, std::span<const T> values) {
  assert(entities.size() == values.size() && "World::insert: one value per entity");
  auto& p = storage<T>();
  p.reserve(p.size() + static_cast<std::uint32_t>(entities.size()));
  for (std::size_t i = 0; i < entities.size(); ++i) add_to(p, entities[i], values[i]);
}

template <class T, class... Args>
T& World::add_to(detail::Pool<T>& p, Entity e, Args&&... args) {
  assert(alive(e) && "World::add: stale or null entity handle");
  assert(write_declared(component_id<T>()) && "a system adds a component it did not declare in SystemDesc::writes");
  std::uint32_t& entry = p.sparse_entry(e.index);
  if (entry != 0) {
    const std::uint32_t pos = entry - 1;
    T& c = p.at(pos);
    if constexpr (std::is_constructible_v<T, Args&&...>)
      c = T(std::forward<Args>(args)...);
    else
      c = T{std::forward<Args>(args)...};
    p.tick(pos) = tick_;
    return c;
  }
  T* c = &p.emplace(e.index, entry, tick_, std::forward<Args>(args)...);
  mask_word(e.index, p.bit_) |= mask_bit(p.bit_);
  if (!p.groups_.empty()) {
    join_groups(p, e.index);
    c = &p.at(p.find(e.index));  // joining a group moves it
  }
  if (p.on_add_.empty()) return *c;
  p.fire(*this, p.on_add_, e);
  // A listener may have removed or replaced it (or moved it by a removal): look it up again.
  T* now = try_get<T>(e);
  assert(now && "an on_add listener removed the component it was told about");
  return *now;
}

template <class T>
bool World::remove(Entity e) {
  assert(write_declared(component_id<T>()) && "a system removes a component it did not declare in SystemDesc::writes");
  auto* p = pool_if<T>();
  if (!p || !alive(e)) return false;
  if (!p->plain_pop_ || iterating_ > 0) return remove_from(*p, e);
  // Nothing to tell and no slot to keep: the typed swap-and-pop.
  const std::uint32_t pos = p->find(e.index);
  if (pos == detail::kNone) return false;
  mask_word(e.index, p->bit_) &= ~mask_bit(p->bit_);
  p->pop(pos, e.index);
  return true;
}

template <class T>
T& World::patch(Entity e) {
  assert(write_declared(component_id<T>()) && "a system patches a component it did not declare in SystemDesc::writes");
  auto* p = pool_if<T>();
  assert(p && alive(e) && "World::patch: the entity lacks this component or the handle is stale");
  const std::uint32_t pos = p->find(e.index);
  assert(pos != detail::kNone && "World::patch: the entity lacks this component");
  p->tick(pos) = tick_;
  return p->at(pos);
}

template <class... T>
View<T...> World::view() {
  return View<T...>(*this);
}

template <class... T, class Fn>
void World::each(Fn&& fn) {
  view<T...>().each(std::forward<Fn>(fn));
}

template <class... Owned, class... Observed>
View<Owned..., Observed...> World::group(Observe<Observed...>) {
  static_assert(sizeof...(Owned) >= 1 && sizeof...(Owned) + sizeof...(Observed) >= 2,
                "a group owns at least one type and has at least two");
  make_group({&storage<Owned>()...}, {&storage<Observed>()...});
  return View<Owned..., Observed...>(*this);
}

template <class T>
ComponentPool<T> World::pool() {
  return ComponentPool<T>(*this, storage<T>());
}

}  // namespace penumbra

template <>
struct std::hash<penumbra::Entity> {
  std::size_t operator()(const penumbra::Entity& e) const noexcept {
    return std::hash<std::uint64_t>{}((std::uint64_t{e.generation} << 32) | e.index);
  }
};
