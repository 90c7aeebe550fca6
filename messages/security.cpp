#include "messages/security.h"

#include <dds/ddsrt/log.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/pkcs7.h>
#include <openssl/x509.h>
#include <openssl/x509_vfy.h>

#include <filesystem>
#include <memory>
#include <mutex>

#include "common/core/bounds.h"
#include "common/core/error.h"
#include "common/core/input_file.h"

namespace nsim::transport {
namespace {

namespace fs = std::filesystem;

// A credential is a certificate or key of about 1 KB or a signed XML document of a few KB; 1 MiB
// refuses nothing real and bounds what is read.
constexpr uint64_t kMaxCredentialBytes = uint64_t{1} << 20;

std::string InDir(const std::string& dir, const std::string& name) {
  return (fs::path(dir) / name).string();
}

// The file's text; InputError naming it when it is missing, unreadable, too large or lacks
// every one of `markers` (what each kind of file must contain).
std::string CheckCredential(const std::string& path, const std::string& what,
                            std::initializer_list<const char*> markers,
                            const std::string& expected) {
  std::string text;
  try {
    text = ReadInputFile(path, what, kMaxCredentialBytes);
  } catch (const InputError& e) {
    throw InputError(Str("DDS Security: ", e.what(),
                         " (scripts/make_credentials.sh --out DIR writes the credentials)"));
  }
  for (const char* marker : markers)
    if (text.find(marker) != std::string::npos) return text;
  throw InputError(Str("DDS Security: ", path, ": not ", expected));
}

// OpenSSL objects, freed on every path out
struct OpenSslFree {
  void operator()(BIO* p) const { BIO_free_all(p); }
  void operator()(X509* p) const { X509_free(p); }
  void operator()(EVP_PKEY* p) const { EVP_PKEY_free(p); }
  void operator()(X509_STORE* p) const { X509_STORE_free(p); }
  void operator()(X509_STORE_CTX* p) const { X509_STORE_CTX_free(p); }
  void operator()(PKCS7* p) const { PKCS7_free(p); }
};
template <typename T>
using OpenSslPtr = std::unique_ptr<T, OpenSslFree>;

// OpenSSL's last error, and its error queue emptied
std::string OpenSslError() {
  const unsigned long code = ERR_peek_last_error();
  ERR_clear_error();
  if (code == 0) return "unknown reason";
  char text[256];
  ERR_error_string_n(code, text, sizeof(text));
  return text;
}

OpenSslPtr<BIO> Memory(const std::string& text) {
  return OpenSslPtr<BIO>(BIO_new_mem_buf(text.data(), static_cast<int>(text.size())));
}

OpenSslPtr<X509> ReadCertificate(const std::string& text, const std::string& path) {
  OpenSslPtr<X509> cert(PEM_read_bio_X509(Memory(text).get(), nullptr, nullptr, nullptr));
  if (!cert)
    throw InputError(
        Str("DDS Security: ", path, ": cannot read the certificate: ", OpenSslError()));
  return cert;
}

// What Cyclone's plugins check when the participant is created, and what they only find at the
// handshake with a peer (a private key that is not the certificate's), checked before with
// OpenSSL so that the message names the file: the certificate is the CA's and valid now, the
// key is the certificate's, both documents are signed by the CA (and the CA valid now).
void VerifyCredentials(const SecurityConfig& s, const std::string& ca_text,
                       const std::string& cert_text, const std::string& key_text,
                       const std::string& governance_text, const std::string& permissions_text) {
  const OpenSslPtr<X509> ca = ReadCertificate(ca_text, s.ca());
  const OpenSslPtr<X509> cert = ReadCertificate(cert_text, s.certificate());
  const OpenSslPtr<X509_STORE> store(X509_STORE_new());
  if (!store || X509_STORE_add_cert(store.get(), ca.get()) != 1)
    throw std::runtime_error(Str("OpenSSL: cannot use the CA certificate: ", OpenSslError()));
  const OpenSslPtr<X509_STORE_CTX> context(X509_STORE_CTX_new());
  if (!context || X509_STORE_CTX_init(context.get(), store.get(), cert.get(), nullptr) != 1)
    throw std::runtime_error(Str("OpenSSL: cannot verify a certificate: ", OpenSslError()));
  if (X509_verify_cert(context.get()) != 1) {
    const int error = X509_STORE_CTX_get_error(context.get());
    ERR_clear_error();
    throw InputError(Str("DDS Security: ", s.certificate(),
                         " is not a valid certificate of the CA ", s.ca(), ": ",
                         X509_verify_cert_error_string(error)));
  }
  // no password: a password-protected key fails instead of prompting on the terminal
  pem_password_cb* no_password = [](char*, int, int, void*) { return 0; };
  const OpenSslPtr<EVP_PKEY> key(
      PEM_read_bio_PrivateKey(Memory(key_text).get(), nullptr, no_password, nullptr));
  if (!key)
    throw InputError(Str("DDS Security: ", s.private_key(),
                         ": cannot read the private key (a password-protected key is not "
                         "supported): ",
                         OpenSslError()));
  if (X509_check_private_key(cert.get(), key.get()) != 1) {
    ERR_clear_error();
    throw InputError(
        Str("DDS Security: ", s.private_key(), " is not the private key of ", s.certificate()));
  }
  for (const auto& [text, path] : {std::pair{&governance_text, s.governance()},
                                   std::pair{&permissions_text, s.permissions()}}) {
    const OpenSslPtr<BIO> input = Memory(*text);
    BIO* content = nullptr;  // the signed part, without its signature
    const OpenSslPtr<PKCS7> signed_document(SMIME_read_PKCS7(input.get(), &content));
    const OpenSslPtr<BIO> content_owner(content);
    if (!signed_document)
      throw InputError(
          Str("DDS Security: ", path, ": not an S/MIME-signed document: ", OpenSslError()));
    // PKCS7_TEXT: the signed content is text/plain (openssl smime -sign -text), as Cyclone reads it
    if (PKCS7_verify(signed_document.get(), nullptr, store.get(), content, nullptr, PKCS7_TEXT) !=
        1)
      throw InputError(
          Str("DDS Security: ", path, " is not signed by the CA ", s.ca(), ": ", OpenSslError()));
  }
}

// where the builtin plugins are: the folder CMake found them in (Debian: libddsc0debian/),
// else the dynamic loader's search path
std::string Plugin(const char* name) {
#ifdef NSIM_DDS_SECURITY_PLUGIN_DIR
  const std::string path = Str(NSIM_DDS_SECURITY_PLUGIN_DIR, "/lib", name, ".so");
  if (fs::exists(path)) return path;
#endif
  return name;
}

std::string FileUri(const std::string& path) {
  return "file:" + fs::absolute(path).lexically_normal().string();
}

// Cyclone's error and warning messages while it exists (Cyclone has one log sink per process:
// the participant is created under a lock)
class LogCapture {
 public:
  LogCapture() { dds_set_log_sink(&LogCapture::Append, this); }
  ~LogCapture() { dds_set_log_sink(nullptr, nullptr); }
  LogCapture(const LogCapture&) = delete;
  LogCapture& operator=(const LogCapture&) = delete;
  const std::string& text() const { return text_; }

 private:
  static void Append(void* self, const dds_log_data_t* data) {
    if (!(data->priority & (DDS_LC_FATAL | DDS_LC_ERROR | DDS_LC_WARNING))) return;
    auto* capture = static_cast<LogCapture*>(self);
    std::string line(data->message, data->size);
    while (!line.empty() && (line.back() == '\n' || line.back() == ' ')) line.pop_back();
    if (line.empty()) return;
    if (!capture->text_.empty()) capture->text_ += "; ";
    capture->text_ += line;
  }
  std::string text_;
};

std::mutex& CreationMutex() {
  static std::mutex mutex;
  return mutex;
}

bool Contains(const std::string& text, const char* part) {
  return text.find(part) != std::string::npos;
}

// The file Cyclone's reason concerns, from the words of the plugins' messages (the codes of
// dds_security_api_err.h, after the step of ddsi_security_omg.c that failed: "validating local
// permission" (sic) is the identity, "validating local permissions" the access control);
// empty when it says nothing about one. What OpenSSL can check was checked before
// (VerifyCredentials): what is left is mostly the content of the documents.
std::string FileOfReason(const SecurityConfig& s, const std::string& reason) {
  if (Contains(reason, "overnance")) return s.governance();
  if (Contains(reason, "permissions") || Contains(reason, "Permissions") ||
      Contains(reason, "Subject name") || Contains(reason, "grant"))
    return s.permissions();
  if (Contains(reason, "rivate key")) return s.private_key();
  if (Contains(reason, "Identity CA")) return s.ca();
  if (Contains(reason, "ertificate") || Contains(reason, "local permission:"))
    return s.certificate();
  return {};
}

}  // namespace

std::string SecurityConfig::ca() const { return InDir(dir, "ca.pem"); }
std::string SecurityConfig::governance() const { return InDir(dir, "governance.p7s"); }
std::string SecurityConfig::certificate() const { return InDir(dir, identity + ".cert.pem"); }
std::string SecurityConfig::private_key() const { return InDir(dir, identity + ".key.pem"); }
std::string SecurityConfig::permissions() const {
  return InDir(dir, identity + ".permissions.p7s");
}

void SecurityConfig::Validate() const {
  if (!enabled()) return;
  CheckName(identity, kMaxPartitionLength, "the DDS Security identity");
  if (!fs::is_directory(dir))
    throw InputError(Str("DDS Security: no such credentials folder '", dir,
                         "' (scripts/make_credentials.sh --out DIR creates one)"));
  const std::string ca_text = CheckCredential(
      ca(), "CA certificate", {"-----BEGIN CERTIFICATE-----"}, "a PEM certificate (the CA's)");
  const std::string cert_text =
      CheckCredential(certificate(), Str("identity certificate of '", identity, "'"),
                      {"-----BEGIN CERTIFICATE-----"}, "a PEM certificate");
  const std::string key_text =
      CheckCredential(private_key(), Str("private key of '", identity, "'"),
                      {"-----BEGIN PRIVATE KEY-----", "-----BEGIN EC PRIVATE KEY-----",
                       "-----BEGIN RSA PRIVATE KEY-----"},
                      "an unencrypted PEM private key");
  const std::initializer_list<const char*> smime = {"application/x-pkcs7-signature",
                                                    "application/pkcs7-signature"};
  const std::string governance_text =
      CheckCredential(governance(), "governance document", smime,
                      "an S/MIME-signed document (openssl smime -sign -text)");
  const std::string permissions_text =
      CheckCredential(permissions(), Str("permissions document of '", identity, "'"), smime,
                      "an S/MIME-signed document (openssl smime -sign -text)");
  VerifyCredentials(*this, ca_text, cert_text, key_text, governance_text, permissions_text);
}

void SetSecurityProperties(const SecurityConfig& s, dds_qos_t* qos) {
  dds_qset_prop(qos, "dds.sec.auth.library.path", Plugin("dds_security_auth").c_str());
  dds_qset_prop(qos, "dds.sec.auth.library.init", "init_authentication");
  dds_qset_prop(qos, "dds.sec.auth.library.finalize", "finalize_authentication");
  dds_qset_prop(qos, "dds.sec.auth.identity_ca", FileUri(s.ca()).c_str());
  dds_qset_prop(qos, "dds.sec.auth.private_key", FileUri(s.private_key()).c_str());
  dds_qset_prop(qos, "dds.sec.auth.identity_certificate", FileUri(s.certificate()).c_str());
  dds_qset_prop(qos, "dds.sec.crypto.library.path", Plugin("dds_security_crypto").c_str());
  dds_qset_prop(qos, "dds.sec.crypto.library.init", "init_crypto");
  dds_qset_prop(qos, "dds.sec.crypto.library.finalize", "finalize_crypto");
  dds_qset_prop(qos, "dds.sec.access.library.path", Plugin("dds_security_ac").c_str());
  dds_qset_prop(qos, "dds.sec.access.library.init", "init_access_control");
  dds_qset_prop(qos, "dds.sec.access.library.finalize", "finalize_access_control");
  dds_qset_prop(qos, "dds.sec.access.permissions_ca", FileUri(s.ca()).c_str());
  dds_qset_prop(qos, "dds.sec.access.governance", FileUri(s.governance()).c_str());
  dds_qset_prop(qos, "dds.sec.access.permissions", FileUri(s.permissions()).c_str());
}

dds_entity_t CreateSecureParticipant(int domain_id, const SecurityConfig& security,
                                     const dds_qos_t* qos) {
  dds_entity_t participant = 0;
  std::string reason;
  {
    const std::lock_guard<std::mutex> lock(CreationMutex());
    const LogCapture log;
    participant = dds_create_participant(domain_id, qos, nullptr);
    reason = log.text();
  }
  if (participant >= 0) return participant;
  if (reason.empty()) reason = dds_strretcode(participant);
  const std::string file = FileOfReason(security, reason);
  throw InputError(Str("DDS Security refused the credentials of '", security.identity, "' in ",
                       security.dir, file.empty() ? std::string() : Str(" (", file, ")"), ": ",
                       reason));
}

std::string PermissionDenied(const SecurityConfig& s, const char* what, const char* topic) {
  return Str("DDS Security: the permissions of '", s.identity, "' (", s.permissions(),
             ") do not allow ", what, " ", topic);
}

}  // namespace nsim::transport
