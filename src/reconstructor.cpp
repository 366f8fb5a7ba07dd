// placeholder until the pipeline lands
#include "trilevel/trilevel.hpp"
namespace trilevel {
struct Reconstructor::Impl { DeviceInfo info; };
Reconstructor::Reconstructor(int) : impl_(std::make_unique<Impl>()) {}
Reconstructor::~Reconstructor() = default;
Reconstructor::Reconstructor(Reconstructor&&) noexcept = default;
Reconstructor& Reconstructor::operator=(Reconstructor&&) noexcept = default;
Mesh Reconstructor::reconstruct(const float*, std::size_t, const Params&, Stats*) { throw Error("not implemented yet"); }
const DeviceInfo& Reconstructor::device() const { return impl_->info; }
std::vector<DeviceInfo> list_devices() { return {}; }
float default_curvature_threshold() { return 1.0f; }
std::string stats_to_json(const Stats&, const Params&) { return "{}"; }
}
