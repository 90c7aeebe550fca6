# Two "machines" on one host: network namespaces <tag>a and <tag>b joined by a veth pair,
# <tag>0 = 10.77.0.1/24 in <tag>a and <tag>1 = 10.77.0.2/24 in <tag>b (the peers of
# configs/dds/two_hosts.xml). Sourced by scripts/two_hosts.sh, scripts/experiment_run.sh
# (--transport two_hosts) and tests/integration/two_hosts_test.sh. Needs root (CAP_SYS_ADMIN,
# CAP_NET_ADMIN).
#
#   netns_pair_up TAG     makes them; sets NETNS_TAG, NETNS_A and NETNS_B; returns 1 when a
#                         step fails (what was made is removed again). TAG: at most 14
#                         characters (the veth ends are interfaces named TAG0 and TAG1)
#   netns_pair_loss PCT   drops PCT % of the packets arriving in each namespace
#   netns_pair_dropped    how many packets each namespace's rule dropped
#   netns_pair_down       removes both namespaces (the veth pair goes with them)

netns_pair_up() {
  local tag="$1"
  NETNS_TAG="$tag"; NETNS_A="${tag}a"; NETNS_B="${tag}b"
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

# netns_pair_loss PCT: drops PCT % (0-100) of the packets arriving on the veth pair in each
# namespace (nftables input rule "numgen random mod 100 < PCT drop"; none for 0); after
# netns_pair_up. Returns 1 when a rule cannot be made.
netns_pair_loss() {
  local pct="$1" ns
  [ "$pct" -gt 0 ] || return 0
  for ns in "$NETNS_A" "$NETNS_B"; do
    ip netns exec "$ns" nft add table inet nsim &&
      ip netns exec "$ns" nft add chain inet nsim input '{ type filter hook input priority 0 ; policy accept ; }' &&
      ip netns exec "$ns" nft add rule inet nsim input iifname "${NETNS_TAG}*" numgen random mod 100 '<' "$pct" counter drop ||
      return 1
  done
}

# netns_pair_dropped: one line per namespace, "NS dropped: packets N bytes M" (after
# netns_pair_loss with PCT > 0)
netns_pair_dropped() {
  local ns
  for ns in "$NETNS_A" "$NETNS_B"; do
    echo "$ns dropped: $(ip netns exec "$ns" nft list chain inet nsim input | grep -o 'packets [0-9]* bytes [0-9]*')"
  done
}
