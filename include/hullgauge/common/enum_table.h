// A function of an enum's values written as a table (docs/style.md point 8):
// one row per enumerator, in the order of the enum's name table
// (enum_names.h), each with what the value maps to — a sentence for an
// operator, the event a status code feeds to a state machine, the register
// value a state shows:
//
//     constexpr auto kPlcStatus = std::to_array<EnumRow<SequencerState, PlcStatus>>(
//         {{SequencerState::Starting, PlcStatus::Starting}, {SequencerState::Ready, PlcStatus::Ready}, ...});
//     PlcStatus plcStatus(SequencerState state) { return mapEnum<kPlcStatus>(state).value_or(PlcStatus::Busy); }
//
// The table is checked where it is used, as a name table is: a row for every
// enumerator, in order, so an enumerator added to the enum and not to the
// table fails to compile instead of falling into a `default:` no one chose
// for it. Only a value that is no enumerator (a cast from a number) has no
// row: mapEnum says so with nullopt, and the caller says what it means.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <type_traits>

#include "hullgauge/common/enum_names.h"

namespace hg {

/// One row of a table that maps each value of the enum E to a T.
template <class E, class T> struct EnumRow {
    E key;
    T value;
};

namespace enum_table_detail {

/// The rows name every enumerator of E once, in the order of E's name table.
template <class E, class T, std::size_t N> constexpr bool coversInOrder(const std::array<EnumRow<E, T>, N>& rows)
{
    const auto& names = enum_names_detail::checkedTable<E>();
    if (rows.size() != names.size()) return false;
    for (std::size_t i = 0; i < rows.size(); ++i)
        if (rows[i].key != names[i].value) return false;
    return true;
}

} // namespace enum_table_detail

/// What `Table` (a constexpr std::array of EnumRow) maps `e` to; nullopt for
/// a value that is no enumerator.
template <const auto& Table, class E> constexpr auto mapEnum(E e)
{
    static_assert(std::is_same_v<decltype(Table[0].key), E>, "the table maps another enum");
    static_assert(enum_table_detail::coversInOrder(Table),
                  "an enum's table has one row per enumerator, in the order of its name table");
    using T = decltype(Table[0].value);
    for (const auto& row : Table)
        if (row.key == e) return std::optional<T>(row.value);
    return std::optional<T>();
}

} // namespace hg
