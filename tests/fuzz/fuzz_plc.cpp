// The PLC server's Modbus TCP requests (docs/fuzzing.md): the input is the
// byte stream of one connection, cut into frames by modbusFrameLength and
// answered by answerModbusRequest, as PlcServer::receive does, on one register
// map that lives across inputs (as a daemon's does across requests). The reply
// must be a well-formed frame for the request it answers.
#include "fuzz_support.h"
#include "plant/plc_registers.h"
#include "plant/plc_server.h"

#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    (void)hg::fuzz::workFolder(); // silences the log
    static hg::daemon::PlcRegisters registers;
    constexpr int kUnitId = 1;
    while (size > 0) {
        const int length = hg::daemon::modbusFrameLength(data, size);
        if (length <= 0) break; // the server closes the connection or waits for more bytes
        const auto answer = hg::daemon::answerModbusRequest(registers, kUnitId, data, length);
        const auto& f = answer.frame;
        // Transaction id echoed, protocol 0, the length field counts what follows it, unit echoed.
        if (f.size() < 9 || f[0] != data[0] || f[1] != data[1] || f[2] != 0 || f[3] != 0 ||
            static_cast<std::size_t>((f[4] << 8) | f[5]) != f.size() - 6 || f[6] != data[6] || f.size() > 260)
            std::abort();
        data += length;
        size -= static_cast<std::size_t>(length);
    }
    return 0;
}
