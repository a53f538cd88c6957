#!/usr/bin/env bash
# Writes throw-away TLS material for the tests into DIR (made at test time, never committed):
#   ca.pem/ca.key                 a CA
#   server.pem/server.key         signed by it, for 127.0.0.1 and localhost (subjectAltName)
#   client.pem/client.key         signed by it, for mutual TLS
#   other_ca.pem/other_ca.key     an unrelated CA
#   other_client.pem/other_client.key  signed by the unrelated CA
# EC P-256 keys (quick to make), valid for 2 days. Usage: make_test_certs.sh DIR
set -euo pipefail
dir=${1:?usage: make_test_certs.sh DIR}
mkdir -p "$dir"
cd "$dir"

# our own configuration: the extensions must not depend on the machine's openssl.cnf
cat >openssl.cnf <<'CNF'
[req]
distinguished_name = dn
prompt = no
[dn]
CN = rbdgrad test
[ca]
basicConstraints = critical,CA:TRUE
keyUsage = critical,keyCertSign,cRLSign
subjectKeyIdentifier = hash
[server]
basicConstraints = CA:FALSE
keyUsage = critical,digitalSignature,keyEncipherment
extendedKeyUsage = serverAuth
subjectAltName = IP:127.0.0.1,DNS:localhost
[client]
basicConstraints = CA:FALSE
keyUsage = critical,digitalSignature,keyEncipherment
extendedKeyUsage = clientAuth
CNF

# openssl's chatter goes to a log, shown when a step fails
trap 'echo "make_test_certs.sh: a step failed; openssl said:" >&2; cat openssl.log >&2' ERR
: >openssl.log
ec=(-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes)

make_ca() {  # NAME CN
  openssl req -config openssl.cnf -x509 -new "${ec[@]}" -keyout "$1.key" -out "$1.pem" -days 2 \
    -subj "/CN=$2" -extensions ca 2>>openssl.log
}

make_leaf() {  # NAME CN CA EXTENSIONS
  openssl req -config openssl.cnf -new "${ec[@]}" -keyout "$1.key" -out "$1.csr" -subj "/CN=$2" 2>>openssl.log
  openssl x509 -req -in "$1.csr" -CA "$3.pem" -CAkey "$3.key" -set_serial "0x$(openssl rand -hex 8)" \
    -out "$1.pem" -days 2 -extfile openssl.cnf -extensions "$4" 2>>openssl.log
  rm -f "$1.csr"
}

make_ca ca "rbdgrad test CA"
make_ca other_ca "rbdgrad unrelated test CA"
make_leaf server localhost ca server
make_leaf client "rbdgrad test client" ca client
make_leaf other_client "rbdgrad unrelated client" other_ca client
