// The implementation of slit_solve.hpp: SlitSolve, GGEM's global solve behind one interface (host or device).
#include "host/solver/slit_solve.hpp"

#include "host/solver/slit_stokes_plan.hpp"
#include "host/solver/slit_stokes_plan_device.hpp"

namespace capsflow {

std::unique_ptr<SlitSolve> make_slit_solve(Backend backend, const SlitGeometry& geo, const GgemGrid& grid) {
#ifdef CAPSFLOW_HAVE_OFFLOAD
  // The device global solve: grids resident for the plan's lifetime.
  if (backend == Backend::Device) return std::make_unique<SlitStokesPlanDevice>(geo, grid);
#endif
  return std::make_unique<SlitStokesPlan>(geo, grid, backend);
}

}  // namespace capsflow
