// World semantics: stale handles, storage against a reference model, structural changes during
// iteration, change ticks, system phases and events.
#include "penumbra/ecs/world.h"

#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "penumbra/core/random.h"

namespace penumbra {
namespace {

struct Position {
  float x = 0, y = 0;
};
struct Velocity {
  float x = 0, y = 0;
};
struct Health {
  int value = 100;
};
// Counts live instances so that tests can check every component is destroyed exactly once.
struct Tracked {
  static inline int live = 0;
  int value = 0;
  explicit Tracked(int v = 0) : value(v) { ++live; }
  Tracked(const Tracked& o) : value(o.value) { ++live; }
  Tracked(Tracked&& o) noexcept : value(o.value) { ++live; }
  Tracked& operator=(const Tracked&) = default;
  Tracked& operator=(Tracked&&) = default;
  ~Tracked() { --live; }
};

// Component types of indexed storage (specialised below, before their first use).
struct Slot {
  float x = 0, y = 0;
};
struct TrackedSlot : Tracked {
  using Tracked::Tracked;
};

}  // namespace

template <>
inline constexpr Storage kComponentStorage<Slot> = Storage::Indexed;
template <>
inline constexpr Storage kComponentStorage<TrackedSlot> = Storage::Indexed;

namespace {

// A uniformly chosen entity of a model's live ones (index -> handle; not empty).
Entity pick_entity(const std::map<std::uint32_t, Entity>& entities, Rng& rng) {
  auto it = entities.begin();
  std::advance(it, rng.next_u32() % entities.size());
  return it->second;
}

std::set<std::uint32_t> visited_indices(World& w) {
  std::set<std::uint32_t> out;
  w.each<Position, Velocity>([&](Entity e, Position&, Velocity&) { out.insert(e.index); });
  return out;
}

TEST(World, StaleHandlesAreDetectedNeverAliased) {
  World w;
  EXPECT_FALSE(w.alive(Entity::null()));
  EXPECT_FALSE(static_cast<bool>(Entity::null()));
  const Entity a = w.create();
  w.add<Health>(a, 7);
  EXPECT_TRUE(w.alive(a));
  w.destroy(a);
  EXPECT_FALSE(w.alive(a));
  EXPECT_EQ(w.try_get<Health>(a), nullptr);
  EXPECT_FALSE(w.has<Health>(a));
  EXPECT_FALSE(w.remove<Health>(a));
  w.destroy(a);  // destroying a stale handle is a no-op

  // The slot is reused under a new generation; the old handle stays stale.
  const Entity b = w.create();
  EXPECT_EQ(b.index, a.index);
  EXPECT_NE(b.generation, a.generation);
  EXPECT_FALSE(w.alive(a));
  EXPECT_TRUE(w.alive(b));
  EXPECT_FALSE(w.has<Health>(b));  // the new entity did not inherit the old component
  w.add<Health>(b, 9);
  EXPECT_EQ(w.try_get<Health>(a), nullptr);
  EXPECT_EQ(w.get<Health>(b).value, 9);
  EXPECT_EQ(w.entity_count(), 1u);
}

TEST(World, AddReplacesAndRemoveReportsAbsence) {
  World w;
  const Entity e = w.create();
  int adds = 0;
  Connection c = w.on_add<Health>([&](World&, Entity) { ++adds; });
  w.add<Health>(e, 1);
  w.add<Health>(e, 2);  // replaces
  EXPECT_EQ(w.get<Health>(e).value, 2);
  EXPECT_EQ(adds, 1);
  EXPECT_EQ(w.count<Health>(), 1u);
  EXPECT_TRUE(w.remove<Health>(e));
  EXPECT_FALSE(w.remove<Health>(e));
  EXPECT_EQ(w.count<Health>(), 0u);
  EXPECT_EQ(w.count<Velocity>(), 0u);  // never used: no pool
  const World& cw = w;
  EXPECT_EQ(cw.try_get<Health>(e), nullptr);
}

TEST(World, CopyComponentsCopiesEveryCopyableTypeWithinAndAcrossWorlds) {
  struct MoveOnly {
    std::unique_ptr<int> value;
  };
  World w;
  const Entity a = w.create(), b = w.create();
  w.add<Position>(a, 1.0f, 2.0f);
  w.add<Tracked>(a, 7);
  w.add<MoveOnly>(a, std::make_unique<int>(3));
  w.add<Health>(b, 5);
  w.add<Position>(b, 9.0f, 9.0f);  // replaced by the copy
  // A group over Position and Health: the copy joins it and a's components stay where views find them.
  w.group<Position, Health>();
  int adds = 0;
  Connection c = w.on_add<Tracked>([&](World&, Entity) { ++adds; });
  const int live = Tracked::live;
  EXPECT_EQ(w.copy_components(a, w, b), 1u);  // MoveOnly skipped
  EXPECT_EQ(w.get<Position>(b).x, 1.0f);
  EXPECT_EQ(w.get<Position>(b).y, 2.0f);
  EXPECT_EQ(w.get<Tracked>(b).value, 7);
  EXPECT_EQ(w.get<Health>(b).value, 5);  // a has none: kept
  EXPECT_FALSE(w.has<MoveOnly>(b));
  EXPECT_EQ(adds, 1);
  EXPECT_EQ(Tracked::live, live + 1);
  EXPECT_EQ(w.get<Position>(a).x, 1.0f);
  EXPECT_EQ(*w.get<MoveOnly>(a).value, 3);
  int members = 0;
  w.each<Position, Health>([&](Entity e, Position& p, Health&) {
    EXPECT_EQ(e, b);
    EXPECT_EQ(p.x, 1.0f);
    ++members;
  });
  EXPECT_EQ(members, 1);

  // Into another World, which has none of these pools yet, and back.
  World held;
  const Entity h = held.create();
  EXPECT_EQ(w.copy_components(b, held, h), 0u);
  EXPECT_EQ(held.get<Health>(h).value, 5);
  EXPECT_EQ(held.get<Tracked>(h).value, 7);
  w.destroy(b);
  const Entity back = w.create();
  EXPECT_EQ(held.copy_components(h, w, back), 0u);
  EXPECT_EQ(w.get<Position>(back).y, 2.0f);
  EXPECT_EQ(w.get<Health>(back).value, 5);
  EXPECT_EQ(adds, 2);
}

TEST(World, ReferencesStayValidAcrossAdds) {
  World w;
  const Entity first = w.create();
  Position& p = w.add<Position>(first, 1.0f, 2.0f);
  // 300k components: the pool's blocks grow past 2 MiB (the huge-page path).
  for (int i = 0; i < 300000; ++i) w.add<Position>(w.create(), float(i), 0.0f);
  EXPECT_EQ(&p, &w.get<Position>(first));
  EXPECT_EQ(p.x, 1.0f);
  EXPECT_EQ(p.y, 2.0f);
  double sum = 0.0;
  w.each<Position>([&](Position& q) { sum += q.x; });
  EXPECT_EQ(sum, 1.0 + 299999.0 * 300000.0 / 2.0);
}

// Random operations checked against a std::map model: storage, views and handles agree.
TEST(World, RandomOperationsMatchAReferenceModel) {
  World w;
  std::map<std::uint32_t, Entity> entities;   // index -> live handle
  std::map<std::uint32_t, float> pos, vel;    // index -> Position::x / Velocity::x
  std::vector<Entity> dead;
  Rng rng = Rng::stream(42, 0);
  const auto pick = [&] { return pick_entity(entities, rng); };
  for (int step = 0; step < 20000; ++step) {
    const std::uint32_t op = rng.next_u32() % 8;
    if (op == 0 || entities.size() < 4) {
      const Entity e = w.create();
      ASSERT_FALSE(entities.count(e.index));
      entities[e.index] = e;
    } else if (op == 1) {
      const Entity e = pick();
      w.destroy(e);
      entities.erase(e.index);
      pos.erase(e.index);
      vel.erase(e.index);
      dead.push_back(e);
    } else if (op == 2 || op == 3) {
      const Entity e = pick();
      const float v = float(step);
      w.add<Position>(e, v, 0.0f);
      pos[e.index] = v;
    } else if (op == 4 || op == 5) {
      const Entity e = pick();
      const float v = float(-step);
      w.add<Velocity>(e, v, 0.0f);
      vel[e.index] = v;
    } else if (op == 6) {
      const Entity e = pick();
      EXPECT_EQ(w.remove<Position>(e), pos.erase(e.index) == 1);
    } else {
      const Entity e = pick();
      EXPECT_EQ(w.remove<Velocity>(e), vel.erase(e.index) == 1);
    }
  }
  ASSERT_EQ(w.entity_count(), entities.size());
  ASSERT_EQ(w.count<Position>(), pos.size());
  ASSERT_EQ(w.count<Velocity>(), vel.size());
  for (const auto& [index, e] : entities) {
    ASSERT_TRUE(w.alive(e));
    const Position* p = w.try_get<Position>(e);
    ASSERT_EQ(p != nullptr, pos.count(index) == 1);
    if (p) {
      EXPECT_EQ(p->x, pos[index]);
    }
    const Velocity* v = w.try_get<Velocity>(e);
    ASSERT_EQ(v != nullptr, vel.count(index) == 1);
    if (v) {
      EXPECT_EQ(v->x, vel[index]);
    }
  }
  for (const Entity e : dead) EXPECT_FALSE(w.alive(e));  // destroyed handles never come back
  std::set<std::uint32_t> both;
  for (const auto& [index, x] : pos)
    if (vel.count(index)) both.insert(index);
  EXPECT_EQ(visited_indices(w), both);
  std::size_t n = 0;
  w.each<Position>([&](Entity e, Position& p) {
    EXPECT_EQ(p.x, pos.at(e.index));
    ++n;
  });
  EXPECT_EQ(n, pos.size());
}

// Handles and iteration order depend only on the sequence of operations.
TEST(World, SameOperationsGiveTheSameHandlesAndOrder) {
  const auto run = [](std::uint64_t seed) {
    World w;
    std::vector<Entity> es;
    Rng rng = Rng::stream(seed, 0);
    for (int step = 0; step < 5000; ++step) {
      const std::uint32_t r = rng.next_u32();
      if (es.empty() || r % 4 == 0) {
        es.push_back(w.create());
      } else {
        const Entity e = es[r / 4 % es.size()];
        if (!w.alive(e)) continue;
        if (r % 4 == 1) w.add<Position>(e, float(step), 0.0f);
        if (r % 4 == 2) w.add<Velocity>(e, float(step), 0.0f);
        if (r % 4 == 3 && step % 3 == 0) w.destroy(e);
      }
    }
    std::vector<std::pair<Entity, float>> order;
    w.each<Position, Velocity>([&](Entity e, Position& p, Velocity&) {
      EXPECT_EQ(w.handle(e.index), e);
      order.emplace_back(e, p.x);
    });
    return order;
  };
  const auto a = run(5);
  EXPECT_GT(a.size(), 100u);
  EXPECT_EQ(a, run(5));
  EXPECT_NE(a, run(6));
}

TEST(World, EveryComponentIsDestroyedExactlyOnce) {
  Tracked::live = 0;
  {
    World w;
    std::vector<Entity> es;
    for (int i = 0; i < 3000; ++i) {
      es.push_back(w.create());
      w.add<Tracked>(es.back(), i);
    }
    for (int i = 0; i < 3000; i += 3) w.remove<Tracked>(es[static_cast<std::size_t>(i)]);
    w.each<Tracked>([&](Entity e, Tracked& t) {
      if (t.value % 3 == 1) w.destroy(e);  // tombstones, compacted afterwards
    });
    EXPECT_EQ(Tracked::live, 1000);
    EXPECT_EQ(w.count<Tracked>(), 1000u);
    w.each<Tracked>([](Tracked& t) { EXPECT_EQ(t.value % 3, 2); });
  }
  EXPECT_EQ(Tracked::live, 0);
}

TEST(World, ViewsVisitTheIntersectionWithEitherCallbackForm) {
  World w;
  std::set<std::uint32_t> expected;
  for (int i = 0; i < 2000; ++i) {
    const Entity e = w.create();
    if (i % 2 == 0) w.add<Position>(e, float(i), 0.0f);
    if (i % 3 == 0) w.add<Velocity>(e, 1.0f, 0.0f);
    if (i % 6 == 0) expected.insert(e.index);
  }
  EXPECT_EQ(visited_indices(w), expected);
  w.each<Velocity, Position>([](Velocity& v, Position& p) { p.y += v.x; });
  float sum = 0;
  w.each<Position>([&](Position& p) { sum += p.y; });
  EXPECT_EQ(sum, float(expected.size()));
  EXPECT_EQ((w.view<Position, Velocity>().count()), expected.size());
  // Read-only views name const components.
  std::size_t n = 0;
  w.each<const Velocity, const Position>([&](const Velocity&, const Position& p) { n += p.y == 1.0f; });
  w.each<const Position>([&](Entity, const Position&) { ++n; });
  EXPECT_EQ(n, expected.size() + w.count<Position>());
}

TEST(World, RemovalDuringIterationSkipsUnreachedAndVisitsOthersOnce) {
  World w;
  std::vector<Entity> es;
  for (int i = 0; i < 3000; ++i) {
    es.push_back(w.create());
    w.add<Position>(es.back(), float(i), 0.0f);
    w.add<Velocity>(es.back());
  }
  // Each visited entity removes the Position of the entity 1500 slots later (not yet reached) and
  // its own Velocity: the later ones must be skipped, everything else visited once.
  std::map<std::uint32_t, int> visits;
  w.each<Position, Velocity>([&](Entity e, Position& p, Velocity&) {
    ++visits[e.index];
    const auto i = static_cast<std::size_t>(p.x);
    if (i < 1500) w.remove<Position>(es[i + 1500]);
    w.remove<Velocity>(e);
    EXPECT_EQ(w.try_get<Velocity>(e), nullptr);
    EXPECT_EQ(&w.get<Position>(e), &p);  // the visited component did not move
  });
  EXPECT_EQ(visits.size(), 1500u);
  for (const auto& [index, count] : visits) {
    EXPECT_EQ(count, 1);
    EXPECT_LT(index, es[1500].index);
  }
  // Compaction after the iteration left consistent pools.
  EXPECT_EQ(w.count<Position>(), 1500u);
  EXPECT_EQ(w.count<Velocity>(), 1500u);  // the unvisited half keeps its Velocity
  for (std::size_t i = 0; i < 1500; ++i) {
    EXPECT_EQ(w.get<Position>(es[i]).x, float(i));
    EXPECT_FALSE(w.has<Velocity>(es[i]));
    EXPECT_TRUE(w.has<Velocity>(es[i + 1500]));
  }
}

TEST(World, AdditionsDuringIterationAreNotVisited) {
  World w;
  for (int i = 0; i < 1500; ++i) w.add<Position>(w.create(), float(i), 0.0f);
  int visits = 0;
  w.each<Position>([&](Position& p) {
    ++visits;
    EXPECT_LT(p.x, 1500.0f);
    w.add<Position>(w.create(), 1e6f, 0.0f);  // grows the pool past a page boundary
  });
  EXPECT_EQ(visits, 1500);
  EXPECT_EQ(w.count<Position>(), 3000u);
}

TEST(World, NestedIterationWithDestroyAndRecreate) {
  World w;
  std::vector<Entity> es;
  for (int i = 0; i < 100; ++i) {
    es.push_back(w.create());
    w.add<Health>(es.back(), i);
  }
  int outer = 0, inner = 0;
  w.each<Health>([&](Entity e, Health& h) {
    ++outer;
    if (h.value == 10) {
      // Destroy every other entity from inside a nested iteration; the destroyed slots are
      // reused at once by new entities, which must not be visited by either loop.
      w.each<Health>([&](Entity f, Health& g) {
        ++inner;
        if (g.value % 2 == 1 && f != e) {
          w.destroy(f);
          w.add<Health>(w.create(), -1);
        }
      });
    }
  });
  EXPECT_EQ(inner, 100);
  // The outer loop saw 0..10 and then only the even values above 10.
  EXPECT_EQ(outer, 11 + 44);
  EXPECT_EQ(w.count<Health>(), 100u);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(w.alive(es[static_cast<std::size_t>(i)]), i % 2 == 0);
}

TEST(World, ChangeTicksSelectPatchedAndAdded) {
  World w;
  std::vector<Entity> es;
  for (int i = 0; i < 10; ++i) {
    es.push_back(w.create());
    w.add<Position>(es.back());
    w.add<Velocity>(es.back());
  }
  const std::uint64_t since = w.tick();
  w.advance_tick();
  w.patch<Position>(es[3]).x = 1;
  w.patch<Velocity>(es[4]).x = 1;  // not the first listed component: not selected
  const Entity fresh = w.create();
  w.add<Position>(fresh);
  w.add<Velocity>(fresh);
  std::set<std::uint32_t> changed;
  w.view<Position, Velocity>().each_changed(since, [&](Entity e, Position&, Velocity&) { changed.insert(e.index); });
  EXPECT_EQ(changed, (std::set<std::uint32_t>{es[3].index, fresh.index}));
  EXPECT_EQ(w.changed_tick<Position>(es[3]), since + 1);
  EXPECT_EQ(w.changed_tick<Position>(es[2]), since);
  EXPECT_EQ(w.changed_tick<Health>(es[2]), 0u);
}

TEST(World, SystemsRunInPhaseOrderAndSeeChangesSinceTheirLastRun) {
  World w;
  std::vector<std::string> order;
  std::vector<std::size_t> mover_seen;
  const auto record = [&](std::string name, Phase phase) {
    SystemDesc d;
    d.name = name;
    d.phase = phase;
    d.run = [&order, name](World&, const SystemContext&) { order.push_back(name); };
    w.add_system(std::move(d));
  };
  record("render", Phase::Render);
  record("input", Phase::Input);
  record("lighting", Phase::Lighting);
  record("input2", Phase::Input);

  // "watch" (Animation) counts the Positions changed since it last ran; "mover" (Lighting) patches
  // one Position per run, after "watch" has run in the same update.
  const Entity a = w.create();
  w.add<Position>(a);
  const Entity b = w.create();
  w.add<Position>(b);
  SystemDesc watch;
  watch.name = "watch";
  watch.phase = Phase::Animation;
  watch.reads = {component_id<Position>()};
  watch.run = [&](World& world, const SystemContext& ctx) {
    std::size_t n = 0;
    world.view<Position>().each_changed(ctx.last_run, [&](Position&) { ++n; });
    mover_seen.push_back(n);
    order.push_back("watch");
  };
  w.add_system(std::move(watch));
  SystemDesc mover;
  mover.name = "mover";
  mover.phase = Phase::Lighting;
  mover.writes = {component_id<Position>()};
  mover.run = [&](World& world, const SystemContext& ctx) {
    if (ctx.last_run == 0) world.patch<Position>(a).x += 1;
  };
  w.add_system(std::move(mover));

  w.update(0.016);
  EXPECT_EQ(order, (std::vector<std::string>{"input", "input2", "watch", "lighting", "render"}));
  w.update(0.016);
  w.patch<Position>(b).x = 5;  // written between updates by game code
  w.update(0.016);
  w.update(0.016);
  // First run: both new; second: mover's write from the first update; third: game code's write.
  EXPECT_EQ(mover_seen, (std::vector<std::size_t>{2, 1, 1, 0}));

  const auto& systems = w.systems();
  ASSERT_EQ(systems.size(), 6u);
  EXPECT_EQ(systems[2].name, "watch");
  EXPECT_EQ(systems[2].reads, std::vector<ComponentId>{component_id<Position>()});
  EXPECT_EQ(systems[4].name, "mover");
  EXPECT_EQ(systems[4].writes, std::vector<ComponentId>{component_id<Position>()});
  for (const SystemInfo& s : systems) {
    EXPECT_EQ(s.runs, 4u);
    EXPECT_GE(s.last_ms, 0.0);
    EXPECT_GT(s.last_run, 0u);
  }
  EXPECT_TRUE(component_name(component_id<Position>()).ends_with("::Position"));
  EXPECT_EQ(component_name(component_id<std::string>()).substr(0, 5), "std::");
  EXPECT_STREQ(to_string(Phase::Lighting), "lighting");
}

TEST(World, EventsSeeTheComponentAndStopWhenDisconnected) {
  World w;
  std::vector<int> added, removed;
  Connection on_add = w.on_add<Health>([&](World& world, Entity e) { added.push_back(world.get<Health>(e).value); });
  Connection on_remove =
      w.on_remove<Health>([&](World& world, Entity e) { removed.push_back(world.get<Health>(e).value); });
  const Entity a = w.create();
  const Entity b = w.create();
  w.add<Health>(a, 1);
  w.add<Health>(b, 2);
  w.remove<Health>(a);
  w.destroy(b);  // fires on_remove while b is still alive
  EXPECT_EQ(added, (std::vector<int>{1, 2}));
  EXPECT_EQ(removed, (std::vector<int>{1, 2}));
  EXPECT_TRUE(on_add.connected());
  on_add.disconnect();
  EXPECT_FALSE(on_add.connected());
  {
    Connection scoped = std::move(on_remove);
  }
  const Entity c = w.create();
  w.add<Health>(c, 3);
  w.remove<Health>(c);
  EXPECT_EQ(added.size(), 2u);
  EXPECT_EQ(removed.size(), 2u);
}

TEST(World, ListenersMayChangeTheWorld) {
  World w;
  // Adding a Position gives a Velocity; removing a Position destroys the entity.
  Connection c1 = w.on_add<Position>([](World& world, Entity e) { world.add<Velocity>(e, 2.0f, 0.0f); });
  Connection c2 = w.on_remove<Position>([](World& world, Entity e) { world.destroy(e); });
  std::vector<Entity> es;
  for (int i = 0; i < 10; ++i) {
    es.push_back(w.create());
    w.add<Position>(es.back());
  }
  EXPECT_EQ(w.count<Velocity>(), 10u);
  w.each<Position>([&](Entity e, Position&) {
    if (e.index % 2 == 0) w.remove<Position>(e);
  });
  EXPECT_EQ(w.entity_count(), 5u);
  EXPECT_EQ(w.count<Velocity>(), 5u);
  EXPECT_EQ(w.count<Position>(), 5u);
  c1.release();  // stays connected for the World's life
  const Entity e = w.create();
  w.add<Position>(e);
  EXPECT_TRUE(w.has<Velocity>(e));
}

TEST(World, ConnectionOutlivingItsWorldIsHarmless) {
  Connection c;
  {
    World w;
    c = w.on_add<Health>([](World&, Entity) {});
    EXPECT_TRUE(c.connected());
  }
  EXPECT_FALSE(c.connected());
  c.disconnect();
}

TEST(World, ResourcesAreSingletonsAndWorldsMove) {
  World w;
  w.resource<Health>().value = 5;
  EXPECT_EQ(&w.resource<Health>(), &w.resource<Health>());
  const Entity e = w.create();
  w.add<Position>(e, 3.0f, 4.0f);
  World moved = std::move(w);
  EXPECT_EQ(moved.resource<Health>().value, 5);
  EXPECT_EQ(moved.get<Position>(e).y, 4.0f);
  const Entity f = moved.create();  // the moved World keeps its mask rows: add and destroy work
  moved.add<Velocity>(f, 1.0f, 2.0f);
  moved.destroy(e);
  EXPECT_EQ(moved.get<Velocity>(f).y, 2.0f);
  EXPECT_EQ(moved.count<Position>(), 0u);
  w = World();  // a moved-from World takes a new one and works again
  const Entity g = w.create();
  w.add<Position>(g, 1.0f, 1.0f);
  w.destroy(g);
  EXPECT_EQ(w.count<Position>(), 0u);
}

#ifndef NDEBUG
TEST(WorldDeathTest, UndeclaredWriteFromASystemAsserts) {
  World w;
  const Entity e = w.create();
  w.add<Position>(e);
  SystemDesc d;
  d.name = "sneaky";
  d.run = [e](World& world, const SystemContext&) { world.patch<Position>(e).x = 1; };
  w.add_system(std::move(d));
  EXPECT_DEATH(w.update(0.0), "did not declare");
}
#endif

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

// Multi-component views remember that pools filled in the same order line up; the memory must
// follow every change of order (removals, swaps, compaction, appends in another order).
TEST(World, AlignedViewMemoFollowsLayoutChanges) {
  World w;
  std::vector<Entity> es;
  for (int i = 0; i < 3000; ++i) {
    const Entity e = w.create();
    w.add<Position>(e, float(e.index));
    w.add<Velocity>(e, float(e.index));
    es.push_back(e);
  }
  auto check = [&](std::size_t expected) {
    std::size_t n = 0;
    w.each<Position, Velocity>([&](Entity e, Position& p, Velocity& v) {
      EXPECT_EQ(p.x, float(e.index));
      EXPECT_EQ(v.x, float(e.index));
      ++n;
    });
    EXPECT_EQ(n, expected);
  };
  check(3000);  // memo established
  w.remove<Velocity>(es[5]);  // Velocity's last slot moves into slot 5: pools no longer line up
  check(2999);
  w.add<Velocity>(es[5], float(es[5].index));  // appended at the end of Velocity only
  check(3000);
  // Appends in opposite orders past the aligned prefix.
  const Entity a = w.create(), b = w.create();
  w.add<Position>(a, float(a.index));
  w.add<Position>(b, float(b.index));
  w.add<Velocity>(b, float(b.index));
  w.add<Velocity>(a, float(a.index));
  check(3002);
  // Removal during iteration leaves tombstones; compaction reorders.
  w.each<Position, Velocity>([&](Entity e, Position&, Velocity&) {
    if (e.index % 7 == 0) w.remove<Position>(e);
  });
  std::size_t kept = 0;
  for (Entity e : es) kept += e.index % 7 != 0;
  kept += (a.index % 7 != 0) + (b.index % 7 != 0);
  check(kept);
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

TEST(World, FindEntityChecksIndicesFromOutside) {
  World w;
  const Entity a = w.create();
  EXPECT_EQ(w.find_entity(a.index), a);
  EXPECT_FALSE(w.find_entity(a.index + 1000));  // never allocated
  w.destroy(a);
  EXPECT_FALSE(w.find_entity(a.index));  // free slot
  const Entity b = w.create();           // reuses the slot under a new generation
  EXPECT_EQ(w.find_entity(b.index), b);
  EXPECT_NE(w.find_entity(b.index), a);
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

TEST(World, SortedEntitiesFollowIndicesNotPoolHistory) {
  World w;
  std::vector<Entity> es;
  for (int i = 0; i < 10; ++i) es.push_back(w.create());
  // Add in reverse, then remove and re-add one, so the pool order is scrambled.
  for (int i = 9; i >= 0; --i) w.add<Position>(es[i]);
  w.remove<Position>(es[9]);
  w.add<Position>(es[9]);
  for (int i = 0; i < 10; i += 2) w.add<Velocity>(es[i]);
  const std::vector<Entity> all = w.view<Position>().sorted_entities();
  EXPECT_EQ(all, es);
  const std::vector<Entity> both = w.view<Velocity, Position>().sorted_entities();
  ASSERT_EQ(both.size(), 5u);
  for (std::size_t i = 0; i < both.size(); ++i) EXPECT_EQ(both[i], es[2 * i]);
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

struct Mass {
  float value = 1.0f;
};

// The group's invariant, through the public API: a walk of one owned pool meets the members
// first, in the order the group's view visits them, and the view visits exactly `expected`.
template <class Owned, class... Group>
void expect_packed(World& w, const std::set<std::uint32_t>& expected) {
  std::vector<std::uint32_t> visited;
  w.each<Group...>([&](Entity e, Group&...) { visited.push_back(e.index); });
  ASSERT_EQ(w.view<Group...>().count(), expected.size());
  ASSERT_EQ(std::set<std::uint32_t>(visited.begin(), visited.end()), expected);
  ASSERT_EQ(visited.size(), expected.size()) << "a member was visited twice";
  std::vector<std::uint32_t> front;
  w.each<Owned>([&](Entity e, Owned&) {
    if (front.size() < expected.size()) front.push_back(e.index);
  });
  EXPECT_EQ(front, visited) << "the members are not packed at the front of an owned pool";
}

TEST(WorldGroup, MembersStayPackedUnderRandomOperations) {
  World w;
  w.group<Position, Velocity>();
  w.group<Health>(observe<Position>);  // Position is owned above and observed here
  std::map<std::uint32_t, Entity> entities;
  std::map<std::uint32_t, float> pos, vel;
  std::map<std::uint32_t, int> health;
  Rng rng = Rng::stream(7, 0);
  const auto pick = [&] { return pick_entity(entities, rng); };
  const auto check = [&]() {
    std::set<std::uint32_t> both, health_pos;
    for (const auto& [index, x] : pos) {
      if (vel.count(index)) both.insert(index);
      if (health.count(index)) health_pos.insert(index);
    }
    expect_packed<Position, Position, Velocity>(w, both);
    expect_packed<Velocity, Position, Velocity>(w, both);
    expect_packed<Health, Health, Position>(w, health_pos);
    w.each<Position, Velocity>([&](Entity e, Position& p, Velocity& v) {
      EXPECT_EQ(p.x, pos[e.index]);
      EXPECT_EQ(v.x, vel[e.index]);
    });
    w.each<Health, Position>([&](Entity e, Health& h, Position&) { EXPECT_EQ(h.value, health[e.index]); });
  };
  for (int step = 0; step < 6000; ++step) {
    const std::uint32_t op = rng.next_u32() % 9;
    if (op == 0 || entities.size() < 4) {
      const Entity e = w.create();
      entities[e.index] = e;
    } else if (op == 1) {
      const Entity e = pick();
      w.destroy(e);
      entities.erase(e.index);
      pos.erase(e.index);
      vel.erase(e.index);
      health.erase(e.index);
    } else if (op == 2) {
      const Entity e = pick();
      w.add<Position>(e, float(step), 0.0f);
      pos[e.index] = float(step);
    } else if (op == 3) {
      const Entity e = pick();
      w.add<Velocity>(e, float(-step), 0.0f);
      vel[e.index] = float(-step);
    } else if (op == 4) {
      const Entity e = pick();
      w.add<Health>(e, step);
      health[e.index] = step;
    } else if (op == 5) {
      const Entity e = pick();
      EXPECT_EQ(w.remove<Position>(e), pos.erase(e.index) == 1);
    } else if (op == 6) {
      const Entity e = pick();
      EXPECT_EQ(w.remove<Velocity>(e), vel.erase(e.index) == 1);
    } else if (op == 7) {
      const Entity e = pick();
      EXPECT_EQ(w.remove<Health>(e), health.erase(e.index) == 1);
    } else {
      // add() returns the component where the group put it.
      const Entity e = pick();
      Velocity& v = w.add<Velocity>(e, 5.0f, 0.0f);
      vel[e.index] = 5.0f;
      EXPECT_EQ(&v, &w.get<Velocity>(e));
    }
    if (step % 500 == 0) check();
  }
  check();
}

TEST(WorldGroup, DeclaringOnAFilledWorldPacksIt) {
  World w;
  std::vector<Entity> es(1000);
  w.create(es);
  std::set<std::uint32_t> both;
  for (std::size_t i = 0; i < es.size(); ++i) {
    w.add<Position>(es[i], float(i), 0.0f);
    if (i % 7 == 3) {
      w.add<Velocity>(es[i]);
      both.insert(es[i].index);
    }
  }
  const auto view = w.group<Position, Velocity>();
  expect_packed<Position, Position, Velocity>(w, both);
  // Every entity kept its own component through the reordering.
  for (std::size_t i = 0; i < es.size(); ++i) EXPECT_EQ(w.get<Position>(es[i]).x, float(i));
  // Asking again returns the same group without repacking or throwing.
  EXPECT_NO_THROW((w.group<Velocity, Position>()));
  EXPECT_EQ((w.view<Position, Velocity>().count()), both.size());
  (void)view;
}

TEST(WorldGroup, ChangesDuringIterationFollowTheViewRulesThenRepack) {
  World w;
  w.group<Position, Velocity>();
  std::vector<Entity> es(3000);
  w.create(es);
  for (std::size_t i = 0; i < es.size(); ++i) {
    w.add<Position>(es[i], float(i), 0.0f);
    w.add<Velocity>(es[i]);
  }
  // Each visited entity of the first half removes the Velocity of one 1500 later (not yet
  // reached: skipped) and gives a fresh entity both components (joins: not visited).
  std::map<std::uint32_t, int> visits;
  std::set<std::uint32_t> joined;
  w.each<Position, Velocity>([&](Entity e, Position& p, Velocity&) {
    ++visits[e.index];
    const auto i = static_cast<std::size_t>(p.x);
    if (i < 1500) {
      w.remove<Velocity>(es[i + 1500]);
      const Entity f = w.create();
      w.add<Position>(f, -1.0f, 0.0f);
      w.add<Velocity>(f);
      joined.insert(f.index);
    }
    EXPECT_EQ(&w.get<Position>(e), &p);  // no slot moves under the iteration
  });
  EXPECT_EQ(visits.size(), 1500u);
  for (const auto& [index, count] : visits) EXPECT_EQ(count, 1);
  for (const std::uint32_t f : joined) EXPECT_FALSE(visits.count(f));
  // After the iteration the group is packed again: the first half and the joiners.
  std::set<std::uint32_t> both = joined;
  for (std::size_t i = 0; i < 1500; ++i) both.insert(es[i].index);
  expect_packed<Position, Position, Velocity>(w, both);
  expect_packed<Velocity, Position, Velocity>(w, both);
}

TEST(WorldGroup, OwnershipConflictsAreNamed) {
  World w;
  w.group<Position, Velocity>();
  try {
    w.group<Velocity, Health>();
    FAIL() << "a second owner was accepted";
  } catch (const std::logic_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("Velocity"), std::string::npos) << what;
    EXPECT_NE(what.find("observe"), std::string::npos) << what;
  }
  EXPECT_NO_THROW(w.group<Health>(observe<Velocity>));
  EXPECT_THROW(w.group<Mass>(observe<Mass>), std::logic_error);
}

TEST(WorldPool, HoistedGetsAgreeWithTheWorld) {
  World w;
  std::vector<Entity> es(100);
  w.create(es);
  for (std::size_t i = 0; i < es.size(); i += 2) w.add<Health>(es[i], int(i));
  const ComponentPool<Health> health = w.pool<Health>();
  for (std::size_t i = 0; i < es.size(); ++i) {
    EXPECT_EQ(health.contains(es[i]), i % 2 == 0);
    EXPECT_EQ(health.try_get(es[i]), w.try_get<Health>(es[i]));
    if (i % 2 == 0) {
      EXPECT_EQ(&health.get(es[i]), &w.get<Health>(es[i]));
    }
  }
  EXPECT_EQ(health.size(), 50u);
  w.destroy(es[0]);
  EXPECT_FALSE(health.contains(es[0]));
  EXPECT_EQ(health.try_get(es[0]), nullptr);  // stale: the generation is checked
  const Entity reused = w.create();
  ASSERT_EQ(reused.index, es[0].index);
  w.add<Health>(reused, 77);
  EXPECT_EQ(health.try_get(es[0]), nullptr);
  EXPECT_EQ(health.get(reused).value, 77);
  EXPECT_EQ(w.pool<Mass>().try_get(reused), nullptr);  // a pool the World had not used yet
}

// Indexed storage: each component sits at its entity's index, one read from a hoisted pool; the
// indices without one are skipped; removals leave the other components where they are.
TEST(WorldIndexed, ComponentsSitAtTheirEntityIndex) {
  World w;
  std::vector<Entity> es(3000);
  w.create(es);
  for (std::size_t i = 0; i < es.size(); i += 3) w.add<Slot>(es[i], float(i), 0.0f);
  const ComponentPool<Slot> slots = w.pool<Slot>();
  EXPECT_EQ(slots.size(), 1000u);
  for (std::size_t i = 0; i < es.size(); ++i) {
    ASSERT_EQ(slots.contains(es[i]), i % 3 == 0);
    EXPECT_EQ(slots.try_get(es[i]), w.try_get<Slot>(es[i]));
    if (i % 3 == 0) {
      EXPECT_EQ(&slots.get(es[i]), &w.get<Slot>(es[i]));
      EXPECT_EQ(slots.get(es[i]).x, float(i));
    }
  }
  // In the pool's region, slot i is element i of one array.
  EXPECT_EQ(&slots.get(es[300]) - &slots.get(es[0]), 300);
  Slot* kept = &w.get<Slot>(es[1500]);
  for (std::size_t i = 0; i < 1500; i += 3) w.remove<Slot>(es[i]);  // no swap-and-pop
  w.destroy(es[2997]);                                               // the last one: trailing holes go
  EXPECT_EQ(&w.get<Slot>(es[1500]), kept);
  EXPECT_EQ(w.count<Slot>(), 499u);
  std::vector<std::uint32_t> seen;
  w.each<Slot>([&](Entity e, Slot& s) {
    EXPECT_EQ(s.x, float(e.index));
    seen.push_back(e.index);
  });
  ASSERT_EQ(seen.size(), 499u);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));  // index order
  EXPECT_EQ(seen.front(), 1500u);
  EXPECT_EQ(seen.back(), 2994u);
  // A stale handle at a reused index is refused; the new entity's component takes the slot.
  w.destroy(es[1500]);
  const Entity reused = w.create();
  ASSERT_EQ(reused.index, es[1500].index);
  EXPECT_EQ(slots.try_get(es[1500]), nullptr);
  w.add<Slot>(reused, -1.0f, 0.0f);
  EXPECT_EQ(&slots.get(reused), kept);
  EXPECT_EQ(slots.try_get(es[1500]), nullptr);
}

// Indexed and dense pools together, through random creates, destroys, adds, replacements and
// removals (some during iteration), agree with a model; views led by either pool visit the
// intersection.
TEST(WorldIndexed, RandomOperationsMatchAReferenceModel) {
  World w;
  std::map<std::uint32_t, Entity> entities;
  std::map<std::uint32_t, float> slot, vel;
  Rng rng = Rng::stream(7, 0);
  const auto pick = [&] { return pick_entity(entities, rng); };
  for (int step = 0; step < 20000; ++step) {
    const std::uint32_t op = rng.next_u32() % 9;
    if (op == 0 || entities.size() < 4) {
      const Entity e = w.create();
      entities[e.index] = e;
    } else if (op == 1) {
      const Entity e = pick();
      w.destroy(e);
      entities.erase(e.index);
      slot.erase(e.index);
      vel.erase(e.index);
    } else if (op <= 3) {
      const Entity e = pick();
      w.add<Slot>(e, float(step), 0.0f);
      slot[e.index] = float(step);
    } else if (op <= 5) {
      const Entity e = pick();
      w.add<Velocity>(e, float(-step), 0.0f);
      vel[e.index] = float(-step);
    } else if (op == 6) {
      const Entity e = pick();
      EXPECT_EQ(w.remove<Slot>(e), slot.erase(e.index) == 1);
    } else if (op == 7) {
      const Entity e = pick();
      EXPECT_EQ(w.remove<Velocity>(e), vel.erase(e.index) == 1);
    } else if (step % 50 == 0) {
      // During iteration: every visited entity whose value is odd loses its Slot.
      w.each<Slot>([&](Entity e, Slot& s) {
        if (int(s.x) % 2 != 0) {
          w.remove<Slot>(e);
          slot.erase(e.index);
        }
      });
    }
  }
  ASSERT_EQ(w.count<Slot>(), slot.size());
  ASSERT_EQ(w.count<Velocity>(), vel.size());
  const ComponentPool<Slot> slots = w.pool<Slot>();
  for (const auto& [index, e] : entities) {
    const Slot* s = w.try_get<Slot>(e);
    ASSERT_EQ(s != nullptr, slot.count(index) == 1);
    if (s) {
      EXPECT_EQ(s->x, slot[index]);
      EXPECT_EQ(&slots.get(e), s);
    }
  }
  std::set<std::uint32_t> both;
  for (const auto& [index, x] : slot)
    if (vel.count(index)) both.insert(index);
  std::set<std::uint32_t> by_slot, by_vel;
  w.each<Slot, Velocity>([&](Entity e, Slot& s, Velocity& v) {
    EXPECT_EQ(s.x, slot.at(e.index));
    EXPECT_EQ(v.x, vel.at(e.index));
    by_slot.insert(e.index);
  });
  w.each<Velocity, Slot>([&](Entity e, Velocity&, Slot&) { by_vel.insert(e.index); });
  EXPECT_EQ(by_slot, both);
  EXPECT_EQ(by_vel, both);
  std::size_t n = 0;
  w.each<Slot>([&](Entity, Slot&) { ++n; });
  EXPECT_EQ(n, slot.size());
}

TEST(WorldIndexed, EveryComponentIsDestroyedExactlyOnce) {
  Tracked::live = 0;
  {
    World w;
    std::vector<Entity> es(3000);
    w.create(es);
    for (std::size_t i = 0; i < es.size(); ++i) w.add<TrackedSlot>(es[i], int(i));
    for (std::size_t i = 0; i < es.size(); i += 3) w.remove<TrackedSlot>(es[i]);
    w.each<TrackedSlot>([&](Entity e, TrackedSlot& t) {
      if (t.value % 3 == 1) w.destroy(e);  // holes left during the iteration
    });
    w.add<TrackedSlot>(es[0], 0);  // into a hole
    w.add<TrackedSlot>(es[0], 3);  // replaced
    EXPECT_EQ(Tracked::live, 1001);
    EXPECT_EQ(w.count<TrackedSlot>(), 1001u);
    w.each<TrackedSlot>([](TrackedSlot& t) { EXPECT_EQ(t.value % 3, t.value == 3 ? 0 : 2); });
  }
  EXPECT_EQ(Tracked::live, 0);
}

TEST(WorldIndexed, NoGroupOwnsIt) {
  World w;
  std::vector<Entity> es(10);
  w.create(es);
  for (std::size_t i = 0; i < es.size(); ++i) {
    if (i % 2 == 0) w.add<Slot>(es[i]);
    if (i % 3 == 0) w.add<Velocity>(es[i]);
  }
  try {
    w.group<Slot, Velocity>();
    FAIL() << "a group took an indexed pool";
  } catch (const std::logic_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("Slot"), std::string::npos) << what;
    EXPECT_NE(what.find("indexed"), std::string::npos) << what;
  }
  w.group<Velocity>(observe<Slot>);  // observing it is fine
  EXPECT_EQ((w.view<Velocity, Slot>().count()), 2u);  // entities 0 and 6
  w.remove<Slot>(es[6]);
  EXPECT_EQ((w.view<Velocity, Slot>().count()), 1u);
}

// Components in a pool's region and, with regions turned off, in blocks, across several pages of
// 1024, agree with a model through adds, replacements and swap-and-pop removals.
TEST(WorldStorage, RegionAndBlockPagesAgreeWithAModel) {
  for (const bool regions : {true, false}) {
    SCOPED_TRACE(regions ? "region" : "blocks");
    detail::Region::enable(regions);
    World w;
    std::vector<Entity> es(2500);
    w.create(es);
    std::map<std::uint32_t, int> model;
    Rng rng = Rng::stream(7, 0);
    for (int step = 0; step < 10000; ++step) {
      const Entity e = es[rng.next_u32() % es.size()];
      if (rng.next_u32() % 3 != 0) {
        w.add<Health>(e, step);
        model[e.index] = step;
      } else {
        EXPECT_EQ(w.remove<Health>(e), model.erase(e.index) == 1);
      }
    }
    detail::Region::enable(true);
    const ComponentPool<Health> health = w.pool<Health>();
    ASSERT_GT(model.size(), 1024u);  // more than one page
    ASSERT_EQ(health.size(), model.size());
    for (const Entity e : es) {
      const auto it = model.find(e.index);
      ASSERT_EQ(health.contains(e), it != model.end());
      if (it != model.end()) {
        EXPECT_EQ(health.get(e).value, it->second);
      }
    }
    std::size_t visited = 0;
    w.each<Health>([&](Entity e, Health& h) {
      EXPECT_EQ(h.value, model.at(e.index));
      ++visited;
    });
    EXPECT_EQ(visited, model.size());
  }
}

// A World's regions serve later pools with the bytes they held: every component reads what its
// constructor wrote, and entities never given one have none.
TEST(WorldStorage, ReusedRegionsHoldOnlyConstructedComponents) {
  constexpr std::size_t kCount = 5000;
  {
    World before;
    std::vector<Entity> es(kCount);
    before.create(es);
    for (const Entity e : es) before.add<Health>(e, -1);
  }
  World w;
  std::vector<Entity> es(kCount);
  w.create(es);
  for (std::size_t i = 0; i < kCount; i += 2) w.add<Health>(es[i]);
  for (std::size_t i = 0; i < kCount; ++i) {
    const Health* h = w.try_get<Health>(es[i]);
    ASSERT_EQ(h != nullptr, i % 2 == 0) << i;
    if (h) {
      EXPECT_EQ(h->value, 100) << i;
    }
  }
}

TEST(World, DestroyRemovesInTheOrderTypesWereFirstUsed) {
  // destroy() takes the components in the order of their pools' first use in this World, typed
  // swap-and-pops for pools nobody listens to; an on_remove listener sees the components after
  // its own still there, and the entities moved into the freed slots keep their values.
  World w;
  std::vector<Entity> es(6);
  w.create(es);
  for (std::size_t i = 0; i < es.size(); ++i) {
    w.add<Position>(es[i], float(i), 0.0f);  // first used: removed first, by a typed pop
    w.add<Health>(es[i], int(i));           // watched
    w.add<Velocity>(es[i], 0.0f, float(i));  // after the watched one
  }
  std::vector<std::string> seen;
  Connection c = w.on_remove<Health>([&](World& world, Entity e) {
    seen.push_back(std::to_string(world.get<Health>(e).value) + (world.has<Position>(e) ? " position" : "") +
                   (world.has<Velocity>(e) ? " velocity" : ""));
  });
  w.destroy(es[0]);
  w.destroy(es[3]);
  EXPECT_EQ(seen, (std::vector<std::string>{"0 velocity", "3 velocity"}));
  for (const std::size_t i : {1, 2, 4, 5}) {
    EXPECT_EQ(w.get<Position>(es[i]).x, float(i));
    EXPECT_EQ(w.get<Health>(es[i]).value, int(i));
    EXPECT_EQ(w.get<Velocity>(es[i]).y, float(i));
  }
  EXPECT_EQ(w.count<Position>(), 4u);
  EXPECT_EQ(w.count<Velocity>(), 4u);
  c.disconnect();
  w.destroy(es[5]);
  w.destroy(es[1]);  // the listener is pruned by now: every component by a typed pop
  EXPECT_EQ(seen.size(), 2u);
  EXPECT_EQ(w.get<Velocity>(es[4]).y, 4.0f);
  EXPECT_EQ(w.get<Health>(es[2]).value, 2);
  EXPECT_EQ(w.count<Health>(), 2u);
}

TEST(WorldBulk, BulkOperationsEqualTheirLoops) {
  World bulk, loop;
  std::vector<Entity> a(300), b(300);
  bulk.create(a);
  for (Entity& e : b) e = loop.create();
  EXPECT_EQ(a, b);
  std::vector<Health> values;
  for (int i = 0; i < 300; ++i) values.push_back(Health{i * 3});
  int added = 0;
  Connection c = bulk.on_add<Health>([&](World& w, Entity e) {
    ++added;
    EXPECT_TRUE(w.has<Health>(e));
  });
  bulk.insert<Health>(a, values);
  bulk.insert<Position>(std::span<const Entity>(a).first(100), Position{2.0f, 3.0f});
  for (std::size_t i = 0; i < b.size(); ++i) {
    loop.add<Health>(b[i], values[i]);
    if (i < 100) loop.add<Position>(b[i], 2.0f, 3.0f);
  }
  EXPECT_EQ(added, 300);
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(bulk.get<Health>(a[i]).value, loop.get<Health>(b[i]).value);
    EXPECT_EQ(bulk.has<Position>(a[i]), loop.has<Position>(b[i]));
  }
  bulk.destroy(std::span<const Entity>(a).subspan(50, 200));
  EXPECT_EQ(bulk.entity_count(), 100u);
  EXPECT_EQ(bulk.count<Health>(), 100u);
  EXPECT_EQ(bulk.count<Position>(), 50u);
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(bulk.alive(a[i]), i < 50 || i >= 250);
  // The freed slots come back in the order the loop would give them.
  std::vector<Entity> again(200);
  bulk.create(again);
  for (const Entity e : std::span<const Entity>(b).subspan(50, 200)) loop.destroy(e);
  for (const Entity e : again) EXPECT_EQ(e, loop.create());
}

// 70 component types: more than one 64-bit mask word per entity.
template <int N>
struct Tag {
  int value = N;
};
template <int... N>
void add_tags(World& w, Entity e, std::integer_sequence<int, N...>) {
  (w.add<Tag<N>>(e), ...);
}
template <int... N>
std::size_t tag_components(const World& w, std::integer_sequence<int, N...>) {
  return (w.count<Tag<N>>() + ...);
}

TEST(World, DestroyFindsComponentsOfMoreTypesThanAMaskWord) {
  World w;
  const Entity early = w.create();
  w.add<Tag<0>>(early);
  w.add<Tag<1>>(early);
  std::vector<Entity> es(20);
  w.create(es);
  for (const Entity e : es) add_tags(w, e, std::make_integer_sequence<int, 70>{});  // the masks widen on the way
  add_tags(w, early, std::make_integer_sequence<int, 70>{});
  EXPECT_EQ(tag_components(w, std::make_integer_sequence<int, 70>{}), 21u * 70u);
  int removed = 0;
  Connection c = w.on_remove<Tag<69>>([&](World&, Entity) { ++removed; });
  w.destroy(early);
  w.destroy(es);
  EXPECT_EQ(removed, 21);
  EXPECT_EQ(tag_components(w, std::make_integer_sequence<int, 70>{}), 0u);
  EXPECT_EQ(w.entity_count(), 0u);
}

// Freed indices wait in their mask rows (word 0) and come back most recently freed first, with
// empty masks, after the masks widen; a moved-from World starts again from index 0.
TEST(World, FreedIndicesComeBackMostRecentFirstWithEmptyMasks) {
  World w;
  std::vector<Entity> es(5);
  w.create(es);
  for (const Entity e : es) w.add<Position>(e, 1.0f, 2.0f);
  for (const std::size_t i : {1, 3, 4}) w.destroy(es[i]);
  add_tags(w, es[0], std::make_integer_sequence<int, 70>{});  // two mask words per entity from here
  std::vector<Entity> again(4);
  w.create(again);
  EXPECT_EQ(again, (std::vector<Entity>{{4, 1}, {3, 1}, {1, 1}, {5, 0}}));
  for (const Entity e : again) {
    EXPECT_FALSE(w.has<Position>(e));
    EXPECT_FALSE(w.has<Tag<0>>(e));
    EXPECT_FALSE(w.has<Tag<69>>(e));
    w.add<Tag<69>>(e);
  }
  EXPECT_EQ(w.entity_count(), 6u);
  EXPECT_EQ(w.count<Tag<69>>(), 5u);
  w.destroy(again[1]);  // a typed pop for each of them: no listeners
  w.destroy(es[0]);
  EXPECT_EQ(w.count<Tag<69>>(), 3u);
  EXPECT_EQ(tag_components(w, std::make_integer_sequence<int, 70>{}), 3u);
  EXPECT_EQ(w.create(), (Entity{0, 1}));
  EXPECT_EQ(w.create(), (Entity{3, 2}));

  World moved = std::move(w);
  EXPECT_EQ(moved.entity_count(), 6u);
  EXPECT_EQ(w.entity_count(), 0u);  // NOLINT(bugprone-use-after-move): a moved-from World is empty
  EXPECT_EQ(w.create(), (Entity{0, 0}));
}

}  // namespace
}  // namespace penumbra
