#!/usr/bin/env bash
# Creates the DDS Security credentials of the nsim processes (OMG DDS Security 1.1, the
# builtin PKI-DH authentication and access-control plugins of Cyclone DDS), with openssl:
#
#   scripts/make_credentials.sh [--out DIR] [--days N] [--force]
#
#   --out DIR   where to write them (default $NSIM_CREDENTIALS_DIR, else results/credentials
#               in the repository)
#   --days N    validity of the certificates and permissions documents (default 365)
#   --force     replace the credentials already in DIR (default: refuse, exit 2)
#
# DIR then holds:
#   ca.pem, ca.key.pem        one CA (EC P-256, self-signed), both the identity CA (it signs
#                             the identity certificates) and the permissions CA (it signs the
#                             governance and permissions documents). ca.key.pem is not needed
#                             to run: keep it off the machines that run nsim.
#   governance.xml/.p7s       the domain rules (domains 0..230, the most Cyclone accepts): authentication required, no
#                             unauthenticated participants, join access control; the three nsim
#                             topics with read and write access control, discovery, liveliness,
#                             metadata and data protection ENCRYPT (AES-GCM)
#   NAME.key.pem, NAME.cert.pem, NAME.permissions.xml/.p7s
#                             for NAME = direct_sim (publishes nsim_SensorFrame and
#                             nsim_SimStatus, subscribes nsim_RobotTarget and nsim_SimStatus),
#                             inverse_sim (publishes nsim_RobotTarget and nsim_SimStatus,
#                             subscribes nsim_SensorFrame and nsim_SimStatus) and observer
#                             (subscribes the three topics, publishes nothing); the subject of
#                             NAME's certificate is CN=NAME,O=nsim; every partition
#   The .p7s files are the XML documents S/MIME-signed by the CA (openssl smime -sign -text);
#   they are what the processes read (direct_sim ... --secure DIR).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${NSIM_CREDENTIALS_DIR:-$root/results/credentials}"
days=365
force=0
while [ $# -gt 0 ]; do
  case "$1" in
    --out)
      [ $# -ge 2 ] || { echo "make_credentials: --out needs a folder" >&2; exit 2; }
      out="$2"; shift 2 ;;
    --out=*) out="${1#--out=}"; shift ;;
    --days)
      [ $# -ge 2 ] || { echo "make_credentials: --days needs a number" >&2; exit 2; }
      days="$2"; shift 2 ;;
    --days=*) days="${1#--days=}"; shift ;;
    --force) force=1; shift ;;
    -h|--help) sed -n '2,29p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "make_credentials: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
# at most 100 years: beyond that the end date passes 2125 and means nothing for a simulator
if ! [[ "$days" =~ ^[0-9]+$ ]] || [ "$days" -lt 1 ] || [ "$days" -gt 36500 ]; then
  echo "make_credentials: --days must be an integer in 1..36500, got '$days'" >&2; exit 2
fi
command -v openssl >/dev/null || {
  echo "make_credentials: openssl is missing (scripts/setup.sh installs it)" >&2; exit 1; }
if [ -e "$out/ca.pem" ] && [ "$force" = 0 ]; then
  echo "make_credentials: $out already holds credentials (ca.pem); --force replaces them" >&2
  exit 2
fi
mkdir -p "$out"
out="$(cd "$out" && pwd)"
# the private keys are created readable by their owner only
umask 077
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# the openssl configuration, self-contained (the result does not depend on the system's
# openssl.cnf): the CA's and the identities' X.509 v3 extensions
cat > "$work/openssl.cnf" <<'EOF'
[ req ]
distinguished_name = req_dn
prompt = no
[ req_dn ]
[ ca_ext ]
basicConstraints = critical, CA:TRUE
# digitalSignature: the CA also signs the governance and permissions documents (S/MIME)
keyUsage = critical, keyCertSign, cRLSign, digitalSignature
subjectKeyIdentifier = hash
[ identity_ext ]
basicConstraints = critical, CA:FALSE
keyUsage = critical, digitalSignature, keyAgreement
subjectKeyIdentifier = hash
authorityKeyIdentifier = keyid
EOF

# NAME PUBLISH SUBSCRIBE: the topics an identity may publish and subscribe to
identities=(
  "direct_sim|nsim_SensorFrame nsim_SimStatus|nsim_RobotTarget nsim_SimStatus"
  "inverse_sim|nsim_RobotTarget nsim_SimStatus|nsim_SensorFrame nsim_SimStatus"
  "observer||nsim_SensorFrame nsim_RobotTarget nsim_SimStatus"
)
topics=(nsim_SensorFrame nsim_RobotTarget nsim_SimStatus)

newkey() { openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$1" 2>/dev/null; }
serial() { echo "0x$(openssl rand -hex 16)"; }
# sign FILE.xml into FILE.p7s with the CA (the permissions CA)
sign() {
  openssl smime -sign -text -in "$1.xml" -out "$1.p7s" -signer "$out/ca.pem" \
    -inkey "$out/ca.key.pem"
}

newkey "$work/ca.key.pem"
openssl req -new -x509 -config "$work/openssl.cnf" -extensions ca_ext -key "$work/ca.key.pem" \
  -subj "/O=nsim/CN=nsim CA" -days "$days" -set_serial "$(serial)" -out "$work/ca.pem"
mv "$work/ca.key.pem" "$work/ca.pem" "$out/"

# permissions validity: from now to the end of the certificates' validity (UTC)
not_before="$(date -u +%Y-%m-%dT%H:%M:%SZ)"
not_after="$(date -u -d "+$days days" +%Y-%m-%dT%H:%M:%SZ)"
domains='<domains><id_range><min>0</min><max>230</max></id_range></domains>'

{
  echo '<?xml version="1.0" encoding="UTF-8"?>'
  echo '<!-- nsim governance (scripts/make_credentials.sh): only authenticated participants'
  echo '     with permissions signed by the nsim CA read or write the nsim topics -->'
  echo '<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"'
  echo '     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">'
  echo '  <domain_access_rules>'
  echo '    <domain_rule>'
  echo "      $domains"
  echo '      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>'
  echo '      <enable_join_access_control>true</enable_join_access_control>'
  echo '      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>'
  echo '      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>'
  echo '      <rtps_protection_kind>NONE</rtps_protection_kind>'
  echo '      <topic_access_rules>'
  for t in "${topics[@]}"; do
    echo '        <topic_rule>'
    echo "          <topic_expression>$t</topic_expression>"
    echo '          <enable_discovery_protection>true</enable_discovery_protection>'
    echo '          <enable_liveliness_protection>true</enable_liveliness_protection>'
    echo '          <enable_read_access_control>true</enable_read_access_control>'
    echo '          <enable_write_access_control>true</enable_write_access_control>'
    echo '          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>'
    echo '          <data_protection_kind>ENCRYPT</data_protection_kind>'
    echo '        </topic_rule>'
  done
  echo '      </topic_access_rules>'
  echo '    </domain_rule>'
  echo '  </domain_access_rules>'
  echo '</dds>'
} > "$out/governance.xml"
sign "$out/governance"

# TOPICS...: a <topics> list
topic_list() {
  echo '          <topics>'
  for t in "$@"; do echo "            <topic>$t</topic>"; done
  echo '          </topics>'
  echo '          <partitions><partition>*</partition></partitions>'
}

for entry in "${identities[@]}"; do
  IFS='|' read -r name publish subscribe <<< "$entry"
  newkey "$out/$name.key.pem"
  openssl req -new -config "$work/openssl.cnf" -key "$out/$name.key.pem" \
    -subj "/O=nsim/CN=$name" -out "$work/$name.csr"
  openssl x509 -req -in "$work/$name.csr" -CA "$out/ca.pem" -CAkey "$out/ca.key.pem" \
    -set_serial "$(serial)" -days "$days" -extfile "$work/openssl.cnf" \
    -extensions identity_ext -out "$out/$name.cert.pem" 2>/dev/null
  # the subject exactly as the access-control plugin compares it (RFC 2253)
  subject="$(openssl x509 -noout -subject -nameopt RFC2253 -in "$out/$name.cert.pem")"
  subject="${subject#subject=}"
  {
    echo '<?xml version="1.0" encoding="UTF-8"?>'
    echo "<!-- nsim permissions of $name (scripts/make_credentials.sh) -->"
    echo '<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"'
    echo '     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">'
    echo '  <permissions>'
    echo "    <grant name=\"$name\">"
    echo "      <subject_name>$subject</subject_name>"
    echo "      <validity><not_before>$not_before</not_before><not_after>$not_after</not_after></validity>"
    echo '      <allow_rule>'
    echo "        $domains"
    if [ -n "$publish" ]; then
      echo '        <publish>'
      # shellcheck disable=SC2086  # a list of words
      topic_list $publish
      echo '        </publish>'
    fi
    echo '        <subscribe>'
    # shellcheck disable=SC2086
    topic_list $subscribe
    echo '        </subscribe>'
    echo '      </allow_rule>'
    echo '      <default>DENY</default>'
    echo '    </grant>'
    echo '  </permissions>'
    echo '</dds>'
  } > "$out/$name.permissions.xml"
  sign "$out/$name.permissions"
done
# the certificates and signed documents are public; the private keys stay 0600
chmod 0644 "$out"/*.pem "$out"/*.xml "$out"/*.p7s
chmod 0600 "$out"/*.key.pem
echo "make_credentials: CA, governance and the identities direct_sim, inverse_sim, observer in $out (valid $days days)"
