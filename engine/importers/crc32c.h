// CRC-32C (Castagnoli, reflected polynomial 0x82F63B78), table-driven, and the
// "masked" form TFRecord files store so that a CRC of data holding CRCs stays
// well distributed.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_CRC32C_H_
#define POINTFORWARD_ENGINE_IMPORTERS_CRC32C_H_

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace pf {

// Extends `crc` (the CRC-32C of earlier bytes, 0 for none) with `size` bytes.
uint32_t Crc32cExtend(uint32_t crc, const void* data, size_t size);

// Returns the CRC-32C of `data`. Crc32c("123456789") == 0xE3069283.
inline uint32_t Crc32c(std::string_view data) { return Crc32cExtend(0, data.data(), data.size()); }

// Returns TFRecord's masked CRC: ((crc >> 15) | (crc << 17)) + 0xa282ead8.
inline uint32_t MaskCrc32c(uint32_t crc) { return ((crc >> 15) | (crc << 17)) + 0xa282ead8u; }

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_CRC32C_H_
