#pragma once
// Cell lists binned on the device (architecture review R7; docs/device.md "Resident data"): the element cell list of
// the local sums (ElementCellList, kernels/local_single_layer) and the node cell list of the step-size rule
// (SlitCells, kernels/slit_cells), built by kernels from node positions resident on the device, into list arrays
// that stay on the device for the run, and the step-size rule's search for the closest nodes of different capsules
// over them. So a device step moves no node data to bin or to choose its step.
//
// The lists are the host ones exactly (same cells, same order inside a cell): per-item cell index, per-cell counts by
// atomics, an exclusive scan of the counts (blocked: block sums, a one-thread scan of the block sums, each block's
// scan), placement by atomic capture, then each cell's slice sorted by id (insertion sort, one thread per cell; cells
// hold tens of items). The atomics make the placement order racy, the sort makes it the stable counting sort's
// ascending ids again: deterministic on any device. The arithmetic (centroids, radii, cell coordinates) is the host
// code's, so the host fallback reproduces the host lists bit for bit; on a GPU the device compiler may contract a
// multiply-add into an FMA, so an element within round-off of a cell face may land in the neighbouring cell (the
// local sums then add the same elements in another order: round-off, as the atomics elsewhere).
//
// Each builder owns its list and the list's device copy (DeviceMirror, attached once and re-attached only when the
// cell grid or the item count changes). Between builds the host vectors of the list are stale: pull() copies the
// device arrays into them (tests, diagnostics). Kernels take the list through their map clauses, which find its
// arrays present and copy nothing. The positions and the mesh are read through map clauses too: present when a
// StepWorkspace has attached them (a Simulation), copied per call otherwise.
//
// Usage (device backend, offload builds only; the constructors throw elsewhere):
//     DeviceElementCells ec(Backend::Device);
//     const ElementCellList& cl = ec.build(Lx, H, Lz, cutoff, ncap, nv, ntri, tri, x, y, z);  // 1 scalar returns
//     local_single_layer_velocity(Backend::Device, cl, ...);
//     DeviceNodeCells nc(Backend::Device);
//     nc.build(Lx, H, Lz, h, n, x, y, z);
//     const double d = nc.min_node_distance_between_capsules(nv, x, y, z, h);          // 1 scalar returns
#include <cstddef>
#include <vector>

#include "kernels/backend.hpp"
#include "kernels/device_mirror.hpp"
#include "kernels/local_single_layer.hpp"
#include "kernels/slit_cells.hpp"

namespace capsflow {

// Scratch of one device counting sort: per-item cells, per-cell fill counters, block sums, all on the device.
class DeviceCountingSort {
 public:
  // Sizes the scratch for ncell cells (re-attached through m only when the cell count changes).
  void reserve(DeviceMirror& m, int ncell);
  // The stable counting sort of items 0..n-1 by cell[i] (device arrays, attached by the caller): start[0:ncell+1]
  // the cells' offsets, order[0:n] the item ids by cell, ascending inside a cell.
  void sort(int ncell, std::size_t n, const int* cell, int* start, int* order);

 private:
  std::vector<int> fill_, block_;
};

class DeviceElementCells {
 public:
  explicit DeviceElementCells(Backend backend);
  // As build_element_cell_list (same checks and errors), on the device; x, y, z hold ncap * nv nodes, tri 3 ntri
  // local ids. One scalar (the largest element radius, which sizes the grid) comes back to the host.
  const ElementCellList& build(double Lx, double H, double Lz, double cutoff, int ncap, int nv, int ntri,
                               const int* tri, const double* x, const double* y, const double* z);
  const ElementCellList& list() const { return cl_; }
  // Copies the list's device arrays to its host vectors.
  const ElementCellList& pull();

 private:
  DeviceMirror mirror_;
  DeviceCountingSort sort_;
  ElementCellList cl_;
  std::vector<double> cx_, cy_, cz_, rad_;  // per element, in id order
  std::vector<int> cell_;                   // per element, in id order
};

class DeviceNodeCells {
 public:
  explicit DeviceNodeCells(Backend backend);
  // As bin_points (same grid and order), on the device. No scalar comes back (the grid depends on n and min_cell).
  const SlitCells& build(double Lx, double H, double Lz, double min_cell, std::size_t n, const double* x,
                         const double* y, const double* z);
  // As min_node_distance_between_capsules over the last build, on the device (a min reduction: exact in any order,
  // so the host's value). One scalar comes back.
  double min_node_distance_between_capsules(int nv, const double* x, const double* y, const double* z,
                                            double limit) const;
  const SlitCells& list() const { return cl_; }
  const SlitCells& pull();

 private:
  DeviceMirror mirror_;
  DeviceCountingSort sort_;
  SlitCells cl_;
};

}  // namespace capsflow
