// pinclear's per-evaluation Pinocchio passes as one C function that compiled code can call.
//
// Why: the compiled step logic (pinclear/stepping) runs every stage of an evaluation inside
// numba; only Pinocchio's tree algorithms live outside it. numba calls
// pinclear_passes through its address, with the addresses of the pin.Model / pin.Data objects
// the Python side owns (model_address / data_address below), so Pinocchio still computes M, b,
// J and dJ, on the very Data whose arrays the kernels already read.
//
// Without bits 4 and 8 the sequence is exactly pinclear.kinematics.update's, so results are
// bit-identical to it:
//   computeJointJacobiansTimeVariation(model, data, q, v)   oMi, J, dJ, v
//   updateFramePlacements(model, data)        (flags & 1)   oMf (force elements read frames)
//   crba(model, data, q, LOCAL)               (flags & 2)   M (upper triangle)
//   nonLinearEffects(model, data, q, v)                     nle
// The position level (flags & 4: the Gauss-Newton iterations of the projections onto the
// constraint manifold, which need placements and Jacobians at each iterate, no velocities):
//   computeJointJacobians(model, data, q)                   oMi, J
//   updateFramePlacements / crba as above     (flags & 1, 2)
// The mass matrix alone (flags & 8: the velocity projection at a q whose positions are done):
//   crba(model, data, q, LOCAL)                             M (upper triangle)
#include <Python.h>

#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/rnea.hpp>

#include <boost/python.hpp>

#include <cstdint>

namespace bp = boost::python;
using Model = pinocchio::Model;
using Data = pinocchio::Data;
using VecMap = Eigen::Map<const Eigen::VectorXd>;

extern "C" __attribute__((visibility("default"))) void pinclear_passes(std::int64_t model_addr, std::int64_t data_addr,
                                                                       std::int64_t q_addr, std::int64_t v_addr,
                                                                       std::int64_t flags)
{
  const Model & model = *reinterpret_cast<const Model *>(model_addr);
  Data & data = *reinterpret_cast<Data *>(data_addr);
  VecMap q(reinterpret_cast<const double *>(q_addr), model.nq);
  VecMap v(reinterpret_cast<const double *>(v_addr), model.nv);
  if (flags & 8) {
    pinocchio::crba(model, data, q, pinocchio::Convention::LOCAL);
    return;
  }
  if (flags & 4) {
    pinocchio::computeJointJacobians(model, data, q);
    if (flags & 1)
      pinocchio::updateFramePlacements(model, data);
    if (flags & 2)
      pinocchio::crba(model, data, q, pinocchio::Convention::LOCAL);
    return;
  }
  pinocchio::computeJointJacobiansTimeVariation(model, data, q, v);
  if (flags & 1)
    pinocchio::updateFramePlacements(model, data);
  if (flags & 2)
    pinocchio::crba(model, data, q, pinocchio::Convention::LOCAL);
  pinocchio::nonLinearEffects(model, data, q, v);
}

namespace {

std::int64_t model_address(bp::object o)
{
  return reinterpret_cast<std::int64_t>(&bp::extract<const Model &>(o)());
}

std::int64_t data_address(bp::object o)
{
  return reinterpret_cast<std::int64_t>(&bp::extract<Data &>(o)());
}

std::int64_t passes_address()
{
  return reinterpret_cast<std::int64_t>(&pinclear_passes);
}

}  // namespace

BOOST_PYTHON_MODULE(_passes)
{
  bp::import("pinocchio");  // pin.Model / pin.Data converters registered before any extract
  bp::def("model_address", &model_address, "Address of the C++ Model a pin.Model wraps.");
  bp::def("data_address", &data_address, "Address of the C++ Data a pin.Data wraps.");
  bp::def("passes_address", &passes_address, "Address of the C function pinclear_passes.");
  bp::scope().attr("PINOCCHIO_VERSION") = PINOCCHIO_VERSION;
}
