#pragma once
/// Captures a bench renders into its --dir are kept there and reused. They are reused only when
/// today's build would render them the same: each set has a stamp (a `.stamp` file beside it)
/// naming the renderer, the options that shape the images and a fingerprint of the renderer's
/// code, and a set whose stamp is missing or differs is rendered again, with a line on stderr.
/// Without it an older build's images would be scored against today's truths, and a change to a
/// renderer would not show in the figures.

#include <string>

namespace hedgefit::bench {

/// The stamp of captures made by `renderer` ("hedgefit" or "povray") with `options` (the bench's
/// own words for everything else that shapes them: scale, camera, seeds, scenes). The
/// fingerprint hashes what today's build makes of small fixed scenes: the renderer's images at a
/// twentieth of the size (hedgefit's) or its scene text (POV-Ray's: the ray tracer itself is
/// Debian's), and the camera model's output; it is computed once per process.
std::string RenderStamp(const std::string& renderer, const std::string& options);

/// Whether `dir` holds the set `set` (a name unique within the directory) stamped `stamp`. When
/// the set's stamp is there but differs, or `dir` holds files of the set (`have_files`) without a
/// stamp, says on stderr, as `program`, that the set is rendered again.
bool StampMatches(const std::string& dir, const std::string& set, const std::string& stamp, bool have_files,
                  const std::string& program);

/// Records that `dir` holds `set` as `stamp` (after its last file is written).
void WriteStamp(const std::string& dir, const std::string& set, const std::string& stamp);

/// Forgets `set`'s stamp (before it is rendered again, so that an interrupted render is not reused).
void RemoveStamp(const std::string& dir, const std::string& set);

}  // namespace hedgefit::bench
