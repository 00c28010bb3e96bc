#include "core/io/ros/provenance.h"

#include <dirent.h>
#include <openssl/evp.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

namespace sweepscan::io {
namespace {

Status HashFile(const std::string& path, EVP_MD_CTX* ctx, const std::atomic<bool>* stop) {
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) return Status::Error(path + ": cannot open: " + std::strerror(errno));
  std::vector<unsigned char> buf(1 << 20);
  size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), f.get())) > 0) {
    if (stop != nullptr && *stop) return Status::Error(path + ": stopped");
    EVP_DigestUpdate(ctx, buf.data(), n);
  }
  if (std::ferror(f.get())) return Status::Error(path + ": read failed: " + std::strerror(errno));
  return Status::Ok();
}

}  // namespace

Status HashBag(const std::string& path, std::string* sha256_hex, const std::atomic<bool>* stop) {
  std::vector<std::string> files;
  struct stat st;
  if (stat(path.c_str(), &st) != 0) return Status::Error(path + ": " + std::strerror(errno));
  if (S_ISDIR(st.st_mode)) {
    std::unique_ptr<DIR, int (*)(DIR*)> d(opendir(path.c_str()), &closedir);
    if (!d) return Status::Error(path + ": " + std::strerror(errno));
    while (const dirent* e = readdir(d.get())) {
      const std::string f = path + "/" + e->d_name;
      if (stat(f.c_str(), &st) == 0 && S_ISREG(st.st_mode)) files.push_back(f);
    }
    std::sort(files.begin(), files.end());
  } else {
    files.push_back(path);
  }
  std::unique_ptr<EVP_MD_CTX, void (*)(EVP_MD_CTX*)> ctx(EVP_MD_CTX_new(), &EVP_MD_CTX_free);
  EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr);
  for (const std::string& f : files) {
    const Status s = HashFile(f, ctx.get(), stop);
    if (!s.ok()) return s;
  }
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_DigestFinal_ex(ctx.get(), digest, &len);
  static const char* kHex = "0123456789abcdef";
  sha256_hex->clear();
  for (unsigned int i = 0; i < len; ++i) {
    sha256_hex->push_back(kHex[digest[i] >> 4]);
    sha256_hex->push_back(kHex[digest[i] & 15]);
  }
  return Status::Ok();
}

}  // namespace sweepscan::io
