#include "common/constraints/constraint_body.h"

#include <atomic>

namespace nsim {

namespace {
std::atomic<std::uint64_t> next_body_uid{1};
}  // namespace

ConstraintBody::ConstraintBody() : uid_(next_body_uid.fetch_add(1)) {}

}  // namespace nsim
