# Two "machines" on one host: network namespaces <tag>a and <tag>b joined by a veth pair,
# <tag>0 = 10.77.0.1/24 in <tag>a and <tag>1 = 10.77.0.2/24 in <tag>b (the peers of
# configs/dds/two_hosts.xml). Sourced by scripts/two_hosts.sh and
# tests/integration/two_hosts_test.sh. Needs root (CAP_SYS_ADMIN, CAP_NET_ADMIN).
#
#   netns_pair_up TAG     makes them; sets NETNS_A and NETNS_B; returns 1 when a step fails
#                         (what was made is removed again)
#   netns_pair_down       removes both namespaces (the veth pair goes with them)

netns_pair_up() {
  local tag="$1"
  NETNS_A="${tag}a"; NETNS_B="${tag}b"
  if ip netns add "$NETNS_A" && ip netns add "$NETNS_B" &&
     ip link add "${tag}0" type veth peer name "${tag}1" &&
     ip link set "${tag}0" netns "$NETNS_A" && ip link set "${tag}1" netns "$NETNS_B" &&
     ip -n "$NETNS_A" addr add 10.77.0.1/24 dev "${tag}0" &&
     ip -n "$NETNS_B" addr add 10.77.0.2/24 dev "${tag}1" &&
     ip -n "$NETNS_A" link set lo up && ip -n "$NETNS_B" link set lo up &&
     ip -n "$NETNS_A" link set "${tag}0" up && ip -n "$NETNS_B" link set "${tag}1" up; then
    return 0
  fi
  netns_pair_down
  return 1
}

netns_pair_down() {
  [ -n "${NETNS_A:-}" ] && ip netns del "$NETNS_A" 2>/dev/null
  [ -n "${NETNS_B:-}" ] && ip netns del "$NETNS_B" 2>/dev/null
  return 0
}
