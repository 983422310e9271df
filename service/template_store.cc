#include "service/template_store.h"

#include <algorithm>
#include <filesystem>
#include <system_error>

#include "core/error.h"
#include "templates/cache.h"

namespace g6d {

std::vector<std::string> TemplateStore::ObjectIds() const {
  std::vector<std::string> ids;
  ids.reserve(banks.size());
  for (const auto& entry : banks) ids.push_back(entry.first);
  return ids;  // std::map keeps them sorted
}

TemplateStore LoadTemplateStore(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (!fs::is_directory(dir, error)) G6D_THROW("templates: '" << dir << "' is not a directory");
  std::vector<fs::path> files;
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
    std::error_code type_error;
    if (it->is_regular_file(type_error)) files.push_back(it->path());
  }
  if (error) G6D_THROW("templates: cannot list '" << dir << "': " << error.message());
  std::sort(files.begin(), files.end());

  TemplateStore store;
  for (const fs::path& file : files) {
    const std::string path = file.string();
    try {
      auto bank = std::make_shared<TemplateBank>(ReadTemplateCache(path));
      const auto existing =
          std::find_if(store.loaded.begin(), store.loaded.end(),
                       [&](const LoadedCache& c) { return c.object_id == bank->object_id; });
      if (existing != store.loaded.end()) {
        store.refused.push_back({path, "duplicate object id '" + bank->object_id +
                                           "' (already loaded from " + existing->path + ")"});
        continue;
      }
      store.loaded.push_back(
          {path, bank->object_id, static_cast<int>(bank->templates.size()), bank->diameter_m});
      store.banks.emplace(bank->object_id, std::move(bank));
    } catch (const std::exception& e) {
      store.refused.push_back({path, e.what()});
    }
  }
  return store;
}

}  // namespace g6d
