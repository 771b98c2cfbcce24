// SPDX-License-Identifier: BSD-3-Clause
#include "plumb/bim/demo_building.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>

#include "plumb/bim/ifc_writer.hpp"
#include "plumb/core/error.hpp"
#include "plumb/core/rng.hpp"

namespace plumb::bim {

namespace {

using Arg = StepArg;

/// Coordinates are written rounded to the micrometre, so 7.35 + 0.06 prints as 7.41.
double snap(double v) {
  const double r = std::round(v * 1e6) / 1e6;
  return r == 0.0 ? 0.0 : r;
}

Vector3d snap(const Vector3d& v) { return Vector3d(snap(v.x()), snap(v.y()), snap(v.z())); }

/// A wall as placed in its storey: local x runs along the wall from `origin`, local y across its
/// thickness, z up.
struct Wall {
  std::uint32_t id = 0;
  std::uint32_t placement = 0;
  Vector3d origin = Vector3d::Zero();  ///< in the storey frame
  Vector3d x_axis = Vector3d::UnitX();
  double length = 0.0, thickness = 0.0;
};

void check_settings(const DemoBuildingSettings& s) {
  auto positive = [](double v, const char* name) {
    PLUMB_CHECK(std::isfinite(v) && v > 0.0, "make_demo_building: " << name << " must be a positive number, got " << v);
  };
  positive(s.length, "length");
  positive(s.width, "width");
  positive(s.storey_height, "storey_height");
  positive(s.slab_thickness, "slab_thickness");
  positive(s.exterior_wall_thickness, "exterior_wall_thickness");
  positive(s.interior_wall_thickness, "interior_wall_thickness");
  positive(s.corridor_width, "corridor_width");
  positive(s.min_room_width, "min_room_width");
  positive(s.door_width, "door_width");
  positive(s.door_height, "door_height");
  positive(s.window_width, "window_width");
  positive(s.window_height, "window_height");
  PLUMB_CHECK(std::isfinite(s.window_sill) && s.window_sill >= 0.0,
              "make_demo_building: window_sill must be >= 0, got " << s.window_sill);
  PLUMB_CHECK(std::isfinite(s.entrance_width) && s.entrance_width >= 0.0,
              "make_demo_building: entrance_width must be >= 0, got " << s.entrance_width);
  PLUMB_CHECK(std::isfinite(s.column_size) && s.column_size >= 0.0,
              "make_demo_building: column_size must be >= 0, got " << s.column_size);
  PLUMB_CHECK(std::isfinite(s.room_width_jitter) && s.room_width_jitter >= 0.0 && s.room_width_jitter < 0.5,
              "make_demo_building: room_width_jitter must be in [0, 0.5), got " << s.room_width_jitter);
  PLUMB_CHECK(s.length <= 1000.0 && s.width <= 1000.0,
              "make_demo_building: length and width must be at most 1000 m, got " << s.length << " x " << s.width);
  PLUMB_CHECK(s.num_storeys >= 1 && s.num_storeys <= 100,
              "make_demo_building: num_storeys must be in [1, 100], got " << s.num_storeys);
  PLUMB_CHECK(s.num_rooms >= 2, "make_demo_building: num_rooms must be >= 2 (one row each side of the corridor), got "
                                    << s.num_rooms);
  PLUMB_CHECK(s.door_width >= 0.9, "make_demo_building: door_width must be >= 0.9 m, got " << s.door_width);
  PLUMB_CHECK(s.min_room_width >= s.door_width + 0.4,
              "make_demo_building: min_room_width " << s.min_room_width << " m leaves no room for a "
                                                    << s.door_width << " m door (needs door_width + 0.4)");
  PLUMB_CHECK(s.min_room_width >= s.window_width + s.column_size + 0.2,
              "make_demo_building: min_room_width " << s.min_room_width << " m is too narrow for a " << s.window_width
                                                    << " m window beside the columns");
  PLUMB_CHECK(s.slab_thickness < s.storey_height, "make_demo_building: slab_thickness " << s.slab_thickness
                                                      << " m must be less than storey_height " << s.storey_height);
  const double clear = s.storey_height - s.slab_thickness;
  PLUMB_CHECK(s.door_height + 0.05 <= clear, "make_demo_building: door_height " << s.door_height
                                                  << " m does not fit under the " << clear << " m ceiling");
  PLUMB_CHECK(s.window_sill + s.window_height + 0.05 <= clear,
              "make_demo_building: window (sill " << s.window_sill << " + height " << s.window_height
                                                  << " m) does not fit under the " << clear << " m ceiling");
  PLUMB_CHECK(s.entrance_width <= s.corridor_width - 0.2 || s.entrance_width == 0.0,
              "make_demo_building: entrance_width " << s.entrance_width << " m must be at most corridor_width - 0.2 m");
  const double depth = 0.5 * (s.width - 2.0 * s.exterior_wall_thickness - s.corridor_width) - s.interior_wall_thickness;
  PLUMB_CHECK(depth >= s.min_room_width + s.column_size,
              "make_demo_building: width " << s.width << " m leaves rooms " << depth
                                           << " m deep beside the corridor (need min_room_width + column_size = "
                                           << s.min_room_width + s.column_size << " m)");
  const int south = (s.num_rooms + 1) / 2;
  const double pitch = (s.length - 2.0 * s.exterior_wall_thickness) / south;
  PLUMB_CHECK(pitch - s.interior_wall_thickness >= s.min_room_width + 0.02,
              "make_demo_building: " << s.num_rooms << " rooms do not fit in a " << s.length << " m building ("
                                     << south << " per side would be " << pitch - s.interior_wall_thickness
                                     << " m wide, min_room_width " << s.min_room_width << " m)");
}

/// Partition positions of one row of `n` rooms between x0 and x1 (n + 1 values, ends included),
/// each clear room width at least min_width (widths jittered by the rng, rounded to the cm).
std::vector<double> row_boundaries(const DemoBuildingSettings& s, int n, double x0, double x1, Rng& rng) {
  const double pitch = (x1 - x0) / n;
  const double slack = pitch - s.interior_wall_thickness - s.min_room_width - 0.02;  // >= 0 (checked)
  const double amplitude = std::min(s.room_width_jitter * pitch, 0.5 * slack);
  std::vector<double> u(static_cast<std::size_t>(n));
  double mean = 0.0;
  for (double& v : u) {
    v = rng.uniform(-1.0, 1.0);
    mean += v / n;
  }
  std::vector<double> b(static_cast<std::size_t>(n) + 1);
  b[0] = x0;
  double acc = x0;
  for (int k = 0; k < n; ++k) {
    acc += pitch + amplitude * (u[static_cast<std::size_t>(k)] - mean);
    b[static_cast<std::size_t>(k) + 1] = std::round(acc * 100.0) / 100.0;
  }
  b[static_cast<std::size_t>(n)] = x1;
  return b;
}

class Generator {
 public:
  explicit Generator(const DemoBuildingSettings& s) : s_(s), w_(writer_settings(s)), rng_(s.seed ^ 0x5DEECE66DULL) {}

  DemoBuildingResult run();

 private:
  static IfcWriterSettings writer_settings(const DemoBuildingSettings& s) {
    IfcWriterSettings ws;
    ws.file_name = s.file_name;
    ws.guid_seed = s.seed;
    ws.description = "ViewDefinition [DesignTransferView]";
    return ws;
  }

  /// IfcProductDefinitionShape of one box [lo, hi] in the element's local frame.
  std::uint32_t box_shape(const Vector3d& lo_in, const Vector3d& hi_in) {
    const Vector3d lo = snap(lo_in), hi = snap(hi_in);
    const Vector3d size = snap(hi - lo);
    const Vector2d centre(snap(0.5 * (lo.x() + hi.x())), snap(0.5 * (lo.y() + hi.y())));
    const std::uint32_t profile =
        w_.add("IFCRECTANGLEPROFILEDEF", {Arg::enumeration("AREA"), Arg::null(),
                                          Arg::ref(w_.axis2_placement_2d(centre)), Arg::real(size.x()),
                                          Arg::real(size.y())});
    const std::uint32_t position = w_.axis2_placement_3d(Vector3d(0.0, 0.0, lo.z()));
    const std::uint32_t solid = w_.add("IFCEXTRUDEDAREASOLID", {Arg::ref(profile), Arg::ref(position),
                                                                Arg::ref(w_.direction({0.0, 0.0, 1.0})),
                                                                Arg::real(size.z())});
    const std::uint32_t rep = w_.add("IFCSHAPEREPRESENTATION", {Arg::ref(body_context_), Arg::string("Body"),
                                                                Arg::string("SweptSolid"), Arg::refs({solid})});
    return w_.add("IFCPRODUCTDEFINITIONSHAPE", {Arg::null(), Arg::null(), Arg::refs({rep})});
  }

  /// An IfcProduct: GlobalId, OwnerHistory, Name, Description, ObjectType, placement, shape, tail.
  std::uint32_t product(const char* type, const std::string& name, std::uint32_t placement, std::uint32_t shape,
                        std::vector<Arg> tail) {
    std::vector<Arg> args = {w_.new_guid(), Arg::null(), Arg::string(name), Arg::null(), Arg::null(),
                             Arg::ref(placement), shape == 0 ? Arg::null() : Arg::ref(shape)};
    args.insert(args.end(), tail.begin(), tail.end());
    return w_.add(type, args);
  }

  std::uint32_t rel(const char* type, std::vector<Arg> tail) {
    std::vector<Arg> args = {w_.new_guid(), Arg::null(), Arg::null(), Arg::null()};
    args.insert(args.end(), tail.begin(), tail.end());
    return w_.add(type, args);
  }

  /// A wall filling the plan rectangle [x0, x1] x [y0, y1] from the floor to the ceiling.
  Wall wall(const std::string& name, bool along_x, double x0, double y0, double x1, double y1, bool exterior) {
    Wall wl;
    if (along_x) {
      wl.origin = Vector3d(x0, y0, 0.0);
      wl.x_axis = Vector3d::UnitX();
      wl.length = x1 - x0;
      wl.thickness = y1 - y0;
    } else {  // local x = +y, local y = -x: the thickness runs from x1 back to x0
      wl.origin = Vector3d(x1, y0, 0.0);
      wl.x_axis = Vector3d::UnitY();
      wl.length = y1 - y0;
      wl.thickness = x1 - x0;
    }
    wl.placement = w_.local_placement(storey_placement_, snap(wl.origin), Vector3d::UnitZ(), wl.x_axis);
    const std::uint32_t shape = box_shape(Vector3d::Zero(), Vector3d(wl.length, wl.thickness, clear_height_));
    wl.id = product("IFCWALL", name, wl.placement, shape,
                    {Arg::null(), Arg::enumeration(exterior ? "STANDARD" : "PARTITIONING")});
    contained_.push_back(wl.id);
    ++result_.num_walls;
    return wl;
  }

  /// An opening [a, a + width] x [z, z + height] (wall-local x and z) through `wl`, filled with a
  /// door or window panel in the middle of the wall's thickness.
  void filling(const Wall& wl, bool door, const std::string& name, double a, double width, double z, double height) {
    const double margin = 0.1;  // the opening reaches past both wall faces
    const std::uint32_t op_placement = w_.local_placement(wl.placement, snap(Vector3d(a, -margin, z)));
    const std::uint32_t op_shape = box_shape(Vector3d::Zero(), Vector3d(width, wl.thickness + 2.0 * margin, height));
    const std::uint32_t opening = product("IFCOPENINGELEMENT", name + " opening", op_placement, op_shape,
                                          {Arg::null(), Arg::enumeration("OPENING")});
    rel("IFCRELVOIDSELEMENT", {Arg::ref(wl.id), Arg::ref(opening)});
    const double panel = door ? 0.04 : 0.06;  // leaf / glazing unit thickness [m]
    const std::uint32_t placement = w_.local_placement(op_placement, Vector3d(0.0, margin, 0.0));
    const double y0 = 0.5 * (wl.thickness - panel);
    const std::uint32_t shape = box_shape(Vector3d(0.0, y0, 0.0), Vector3d(width, y0 + panel, height));
    std::uint32_t id;
    if (door) {
      id = product("IFCDOOR", name, placement, shape,
                   {Arg::null(), Arg::real(snap(height)), Arg::real(snap(width)), Arg::enumeration("DOOR"),
                    Arg::enumeration("SINGLE_SWING_LEFT"), Arg::null()});
      ++result_.num_doors;
    } else {
      id = product("IFCWINDOW", name, placement, shape,
                   {Arg::null(), Arg::real(snap(height)), Arg::real(snap(width)), Arg::enumeration("WINDOW"),
                    Arg::enumeration("SINGLE_PANEL"), Arg::null()});
      ++result_.num_windows;
    }
    rel("IFCRELFILLSELEMENT", {Arg::ref(opening), Arg::ref(id)});
    contained_.push_back(id);
  }

  /// A window centred `centre_along` metres along the wall from its origin.
  void window_at(const Wall& wl, const std::string& name, double centre_along, double width) {
    filling(wl, false, name, centre_along - 0.5 * width, width, s_.window_sill, s_.window_height);
  }

  std::uint32_t slab(const std::string& name, double z0, double z1, bool roof) {
    const std::uint32_t placement = w_.local_placement(storey_placement_, Vector3d::Zero());
    const std::uint32_t shape = box_shape(Vector3d(0.0, 0.0, z0), Vector3d(s_.length, s_.width, z1));
    const std::uint32_t id =
        product("IFCSLAB", name, placement, shape, {Arg::null(), Arg::enumeration(roof ? "ROOF" : "FLOOR")});
    contained_.push_back(id);
    ++result_.num_slabs;
    return id;
  }

  void column(const std::string& name, double x0, double y0) {
    const std::uint32_t placement = w_.local_placement(storey_placement_, snap(Vector3d(x0, y0, 0.0)));
    const std::uint32_t shape = box_shape(Vector3d::Zero(), Vector3d(s_.column_size, s_.column_size, clear_height_));
    contained_.push_back(product("IFCCOLUMN", name, placement, shape, {Arg::null(), Arg::enumeration("COLUMN")}));
    ++result_.num_columns;
  }

  void space(const DemoSpace& sp) {
    const std::uint32_t placement =
        w_.local_placement(storey_placement_, snap(Vector3d(sp.min.x(), sp.min.y(), 0.0)));
    const Vector2d size = sp.max - sp.min;
    const std::uint32_t shape = box_shape(Vector3d::Zero(), Vector3d(size.x(), size.y(), clear_height_));
    spaces_.push_back(product("IFCSPACE", sp.name, placement, shape,
                              {Arg::null(), Arg::enumeration("ELEMENT"), Arg::enumeration("INTERNAL"), Arg::null()}));
    result_.spaces.push_back(sp);
  }

  void storey(int k, std::uint32_t building_placement, std::vector<std::uint32_t>& storeys);

  const DemoBuildingSettings& s_;
  IfcWriter w_;
  Rng rng_;
  DemoBuildingResult result_;
  std::uint32_t body_context_ = 0;
  std::uint32_t storey_placement_ = 0;
  double clear_height_ = 0.0;
  std::vector<std::uint32_t> contained_;  ///< elements of the current storey
  std::vector<std::uint32_t> spaces_;     ///< spaces of the current storey
  std::vector<double> south_, north_;     ///< partition positions of the two rows (same on every storey)
  std::vector<double> south_doors_, north_doors_;  ///< door start x per room
};

void Generator::storey(int k, std::uint32_t building_placement, std::vector<std::uint32_t>& storeys) {
  const DemoBuildingSettings& s = s_;
  const double L = s.length, W = s.width, te = s.exterior_wall_thickness, ti = s.interior_wall_thickness;
  const double cs = s.column_size;
  const double yc0 = 0.5 * (W - s.corridor_width), yc1 = 0.5 * (W + s.corridor_width);
  const double elevation = snap(k * s.storey_height);
  const std::string tag = s.num_storeys > 1 ? " (storey " + std::to_string(k) + ")" : std::string();

  storey_placement_ = w_.local_placement(building_placement, Vector3d(0.0, 0.0, elevation));
  const std::uint32_t st =
      product("IFCBUILDINGSTOREY", k == 0 ? "Ground floor" : "Floor " + std::to_string(k), storey_placement_, 0,
              {Arg::null(), Arg::enumeration("ELEMENT"), Arg::real(elevation)});
  storeys.push_back(st);
  contained_.clear();
  spaces_.clear();

  slab("Floor slab" + tag, -s.slab_thickness, 0.0, false);

  // Exterior walls: south and north run the full length, west and east fit between them.
  const Wall south = wall("Exterior wall south" + tag, true, 0.0, 0.0, L, te, true);
  const Wall north = wall("Exterior wall north" + tag, true, 0.0, W - te, L, W, true);
  const Wall west = wall("Exterior wall west" + tag, false, 0.0, te, te, W - te, true);
  const Wall east = wall("Exterior wall east" + tag, false, L - te, te, L, W - te, true);
  // Corridor walls.
  const Wall corr_s = wall("Corridor wall south" + tag, true, te, yc0 - ti, L - te, yc0, false);
  const Wall corr_n = wall("Corridor wall north" + tag, true, te, yc1, L - te, yc1 + ti, false);

  const double cw = std::min(s.window_width, s.corridor_width - 0.2);
  if (k == 0 && s.entrance_width > 0.0) {
    filling(west, true, "Entrance door", 0.5 * W - 0.5 * s.entrance_width - te, s.entrance_width, 0.0,
            s.door_height);
  } else {
    window_at(west, "Window corridor west" + tag, 0.5 * W - te, cw);
  }
  window_at(east, "Window corridor east" + tag, 0.5 * W - te, cw);

  int room = 0;
  for (int side = 0; side < 2; ++side) {
    const bool is_south = side == 0;
    const std::vector<double>& b = is_south ? south_ : north_;
    const std::vector<double>& doors = is_south ? south_doors_ : north_doors_;
    const int n = static_cast<int>(b.size()) - 1;
    const double ry0 = is_south ? te : yc1 + ti;
    const double ry1 = is_south ? yc0 - ti : W - te;
    for (int r = 0; r < n; ++r) {
      const auto ru = static_cast<std::size_t>(r);
      const std::string name = "Room " + std::to_string(++room) + tag;
      DemoSpace sp;
      sp.name = name;
      sp.storey = k;
      sp.min = Vector2d(snap(r == 0 ? b[0] : b[ru] + 0.5 * ti), snap(ry0));
      sp.max = Vector2d(snap(r == n - 1 ? b[ru + 1] : b[ru + 1] - 0.5 * ti), snap(ry1));
      space(sp);
      // Door into the corridor, window in the exterior wall (centred on the room).
      filling(is_south ? corr_s : corr_n, true, "Door " + name, doors[ru] - te, s.door_width, 0.0, s.door_height);
      window_at(is_south ? south : north, "Window " + name, 0.5 * (sp.min.x() + sp.max.x()), s.window_width);
      if (r + 1 < n) {  // partition to the next room, and a column where it meets the exterior wall
        const double x = b[ru + 1];
        const std::string pname = "Partition " + std::to_string(room) + "/" + std::to_string(room + 1) + tag;
        if (is_south) {
          wall(pname, false, x - 0.5 * ti, te + cs, x + 0.5 * ti, yc0 - ti, false);
          if (cs > 0.0) column("Column " + pname.substr(10), x - 0.5 * cs, te);
        } else {
          wall(pname, false, x - 0.5 * ti, yc1 + ti, x + 0.5 * ti, W - te - cs, false);
          if (cs > 0.0) column("Column " + pname.substr(10), x - 0.5 * cs, W - te - cs);
        }
      }
    }
  }
  DemoSpace corridor;
  corridor.name = "Corridor" + tag;
  corridor.storey = k;
  corridor.min = Vector2d(snap(te), snap(yc0));
  corridor.max = Vector2d(snap(L - te), snap(yc1));
  space(corridor);

  if (k + 1 == s.num_storeys) slab("Roof slab" + tag, clear_height_, s.storey_height, true);

  rel("IFCRELAGGREGATES", {Arg::ref(st), Arg::refs(spaces_)});
  rel("IFCRELCONTAINEDINSPATIALSTRUCTURE", {Arg::refs(contained_), Arg::ref(st)});
  result_.gross_floor_area += L * W;
}

DemoBuildingResult Generator::run() {
  const DemoBuildingSettings& s = s_;
  clear_height_ = s.storey_height - s.slab_thickness;

  // Plan shared by every storey.
  const double te = s.exterior_wall_thickness;
  const int num_south = (s.num_rooms + 1) / 2, num_north = s.num_rooms / 2;
  south_ = row_boundaries(s, num_south, te, s.length - te, rng_);
  north_ = row_boundaries(s, num_north, te, s.length - te, rng_);
  for (int side = 0; side < 2; ++side) {
    const std::vector<double>& b = side == 0 ? south_ : north_;
    std::vector<double>& doors = side == 0 ? south_doors_ : north_doors_;
    for (std::size_t r = 0; r + 1 < b.size(); ++r) {
      const double lo = (r == 0 ? b[r] : b[r] + 0.5 * s.interior_wall_thickness) + 0.2;
      const double hi = (r + 2 == b.size() ? b[r + 1] : b[r + 1] - 0.5 * s.interior_wall_thickness) - 0.2 - s.door_width;
      const double lo_cm = std::ceil(lo * 100.0), hi_cm = std::floor(hi * 100.0);
      PLUMB_CHECK(hi_cm >= lo_cm, "make_demo_building: internal error: no place for a door in room " << r);
      doors.push_back((lo_cm + std::floor(rng_.uniform() * (hi_cm - lo_cm + 1.0))) / 100.0);
    }
  }

  // Project, contexts, units.
  const std::uint32_t wcs = w_.axis2_placement_3d(Vector3d::Zero());
  const std::uint32_t model_context =
      w_.add("IFCGEOMETRICREPRESENTATIONCONTEXT",
             {Arg::null(), Arg::string("Model"), Arg::integer(3), Arg::real(1e-5), Arg::ref(wcs), Arg::null()});
  body_context_ = w_.add("IFCGEOMETRICREPRESENTATIONSUBCONTEXT",
                         {Arg::string("Body"), Arg::string("Model"), Arg::derived(), Arg::derived(), Arg::derived(),
                          Arg::derived(), Arg::ref(model_context), Arg::null(), Arg::enumeration("MODEL_VIEW"),
                          Arg::null()});
  const std::uint32_t units = w_.si_units();
  const std::uint32_t project =
      w_.add("IFCPROJECT", {w_.new_guid(), Arg::null(), Arg::string(s.name), Arg::null(), Arg::null(), Arg::null(),
                            Arg::null(), Arg::refs({model_context}), Arg::ref(units)});

  const std::uint32_t site_placement = w_.local_placement(0, Vector3d::Zero());
  const std::uint32_t site = product("IFCSITE", "Site", site_placement, 0,
                                     {Arg::null(), Arg::enumeration("ELEMENT"), Arg::null(), Arg::null(), Arg::null(),
                                      Arg::null(), Arg::null()});
  const std::uint32_t building_placement = w_.local_placement(site_placement, Vector3d::Zero());
  const std::uint32_t building = product("IFCBUILDING", s.name, building_placement, 0,
                                         {Arg::null(), Arg::enumeration("ELEMENT"), Arg::null(), Arg::null(), Arg::null()});
  rel("IFCRELAGGREGATES", {Arg::ref(project), Arg::refs({site})});
  rel("IFCRELAGGREGATES", {Arg::ref(site), Arg::refs({building})});

  std::vector<std::uint32_t> storeys;
  for (int k = 0; k < s.num_storeys; ++k) storey(k, building_placement, storeys);
  rel("IFCRELAGGREGATES", {Arg::ref(building), Arg::refs(storeys)});

  result_.ifc = w_.str();
  return std::move(result_);
}

}  // namespace

DemoBuildingResult make_demo_building(const DemoBuildingSettings& settings) {
  check_settings(settings);
  Generator g(settings);
  return g.run();
}

DemoBuildingResult write_demo_building(const std::string& path, const DemoBuildingSettings& settings) {
  DemoBuildingResult r = make_demo_building(settings);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  PLUMB_CHECK(out.good(), path << ": cannot open for writing");
  out.write(r.ifc.data(), static_cast<std::streamsize>(r.ifc.size()));
  out.flush();
  PLUMB_CHECK(out.good(), path << ": write failed");
  return r;
}

}  // namespace plumb::bim
